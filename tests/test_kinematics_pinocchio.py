"""Kinematics and task space against Pinocchio (issue 9, section 4), on every example-robot-data URDF (fixed and
floating base) and on random trees.

Frames are matched by name: a URDF link with Pinocchio's BODY frame, a URDF joint with its JOINT or
FIXED_JOINT frame (ours is named ``joint:NAME`` when a link has the joint's name).  Every frame's placement
is compared; Jacobians (three references, with and without a point offset, Pinocchio's side by an added
OP_FRAME at that point), velocities, spatial and classical accelerations and Jdot v on a sample of frames (the
last one, usually an end effector, and a few random ones).  Relative error 1e-10 (M^-1: or cond(M) eps).
"""

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from robots import ALL_TYPES, erd, erd_urdfs, random_state, random_urdf
from test_pinocchio import RTOL, PinMap, _pin_loads, a_tol, pin_model, rel_err

REFS = {"world": pin.WORLD, "local": pin.LOCAL, "local_world_aligned": pin.LOCAL_WORLD_ALIGNED}


def pin_frame_ids(model, pm):
    """Pinocchio's frame index for each of our frames, in model.frame_names order."""
    by_name = {}
    for k, fr in enumerate(pm.frames):
        by_name.setdefault(fr.name, []).append((fr.type, k))
    ids = []
    for name in model.frame_names:
        joint = name.startswith("joint:")
        cands = by_name[name[6:] if joint else name]
        body = [k for t, k in cands if t == pin.BODY]
        jnt = [k for t, k in cands if t in (pin.JOINT, pin.FIXED_JOINT)]
        ids.append(body[0] if body and not joint else jnt[0])
    return ids


def cols(J, rows):
    """Pinocchio returns a one-column matrix as a vector."""
    return np.reshape(J, (rows, -1))


def compare_kinematics(model, pm, rng, n_frames=4):
    """Every quantity of section 1 against Pinocchio at one random state; returns {quantity: relative error}."""
    mp = PinMap(model, pm)
    q, v, a = random_state(model, rng)
    qp, vp, ap = mp.q(q), mp.v(v), mp.v(a)
    ids = pin_frame_ids(model, pm)
    nf = len(ids)
    sample = sorted({nf - 1, *rng.integers(0, nf, n_frames - 1).tolist()})
    # Pinocchio's side of a point offset: an OP_FRAME at that point on a copy of the model
    pm2 = pin.Model(pm)
    points = {}
    for k in sample:
        fr = pm.frames[ids[k]]
        points[k] = rng.normal(scale=0.2, size=3)
        pm2.addFrame(pin.Frame(f"pt{k}", fr.parentJoint, ids[k], fr.placement * pin.SE3(np.eye(3), points[k]),
                               pin.OP_FRAME))
    pd, pd0, pd2 = pm.createData(), pm.createData(), pm2.createData()
    pin.forwardKinematics(pm, pd, qp, vp, ap)
    pin.updateFramePlacements(pm, pd)
    pin.forwardKinematics(pm, pd0, qp, vp, 0 * ap)
    err = {}

    def record(what, x, ref):
        err[what] = max(err.get(what, 0.0), rel_err(x, ref))

    T = dynamics.forward_kinematics(model, q)
    record("placement", T, np.array([pd.oMf[i].homogeneous for i in ids]))
    for k in sample:
        name, fid = model.frame_names[k], ids[k]
        record("placement", dynamics.frame_placement(model, q, name), pd.oMf[fid].homogeneous)
        for ref, pref in REFS.items():
            J = dynamics.frame_jacobian(model, q, name, reference=ref)
            record("jacobian", J, cols(pin.computeFrameJacobian(pm, pd, qp, fid, pref), 6)[:, mp.v_perm])
            Jp = dynamics.frame_jacobian(model, q, k, reference=ref, point=points[k])
            pid = pm2.getFrameId(f"pt{k}")
            record("jacobian with point", Jp, cols(pin.computeFrameJacobian(pm2, pd2, qp, pid, pref), 6)[:, mp.v_perm])
            record("velocity", dynamics.frame_velocity(model, q, v, name, reference=ref),
                   pin.getFrameVelocity(pm, pd, fid, pref).vector)
            record("spatial acceleration",
                   dynamics.frame_acceleration(model, q, v, a, name, reference=ref, classical=False),
                   pin.getFrameAcceleration(pm, pd, fid, pref).vector)
            record("classical acceleration", dynamics.frame_acceleration(model, q, v, a, name, reference=ref),
                   pin.getFrameClassicalAcceleration(pm, pd, fid, pref).vector)
            record("Jdot v", dynamics.frame_bias_acceleration(model, q, v, name, reference=ref),
                   pin.getFrameClassicalAcceleration(pm, pd0, fid, pref).vector)
    record("center of mass", dynamics.center_of_mass(model, q), pin.centerOfMass(pm, pd, qp, vp))
    record("center of mass velocity", dynamics.center_of_mass_velocity(model, q, v), pd.vcom[0])
    record("com jacobian", dynamics.com_jacobian(model, q), cols(pin.jacobianCenterOfMass(pm, pd, qp), 3)[:, mp.v_perm])
    record("total mass", model.total_mass, pin.computeTotalMass(pm))
    M = dynamics.mass_matrix(model, q)
    try:
        Minv = dynamics.inverse_mass_matrix(model, q)
    except dynamics.InputError as e:  # a joint that moves no mass (Romeo's thumb): M really is singular
        name = str(e).split("'")[1]
        assert "singular" in str(e) and abs(M[model.v_index[model.joint_index(name)]] ).max() < 1e-12, str(e)
    else:
        Mp = pin.computeMinverse(pm, pd, qp)
        err["M^-1"] = rel_err(Minv, mp.M_back(np.reshape(Mp, M.shape))) * RTOL / a_tol(M)  # scaled: < RTOL means within a_tol
    return err


def assert_all_within(err):
    bad = {k: e for k, e in err.items() if not e < RTOL}
    assert not bad, f"relative errors above {RTOL}: {bad}"


ERD = erd_urdfs()


@pytest.mark.parametrize("rel", ERD)
@pytest.mark.parametrize("floating", [False, True], ids=["fixed", "floating"])
def test_example_robot_data_kinematics_match_pinocchio(rel, floating):
    pm = _pin_loads(erd(rel), floating)
    model = None if pm is None else load_ours(erd(rel), floating)
    if model is None:
        pytest.skip("Pinocchio refuses this URDF")
    if model.nv:
        assert_all_within(compare_kinematics(model, pm, np.random.default_rng(abs(hash(rel)) % 2**32)))


def load_ours(path, floating):
    """Our model of the URDF (non-physical inertias accepted and mimic joints free, as Pinocchio's default
    loads it)."""
    return dynamics.load_urdf(path, floating_base=floating, strict_inertia=False, mimic="independent")


@pytest.mark.parametrize("seed", range(10))
def test_random_trees_kinematics_match_pinocchio(seed):
    rng = np.random.default_rng(1000 + seed)
    text = random_urdf(rng, n_links=int(rng.integers(2, 14)), floating_joint=seed % 3 == 0)
    floating = seed % 4 == 1 and seed % 3 != 0
    model = dynamics.load_urdf(text, floating_base=floating)
    pm = pin.buildModelFromXML(text, pin.JointModelFreeFlyer()) if floating else pin.buildModelFromXML(text)
    assert_all_within(compare_kinematics(model, pm, rng, n_frames=6))


@pytest.mark.parametrize("seed", range(4))
def test_random_trees_with_every_joint_type_kinematics_match_pinocchio(seed):
    """Planar (axis z or not) and spherical joints among the others, fixed and floating bases."""
    rng = np.random.default_rng(2000 + seed)
    text = random_urdf(rng, n_links=int(rng.integers(5, 12)), types=ALL_TYPES, floating_joint=seed == 2)
    floating = seed == 1
    model = dynamics.load_urdf(text, floating_base=floating)
    assert {"planar", "spherical"} & set(model.joint_types)
    assert_all_within(compare_kinematics(model, pin_model(text, model, floating), rng, n_frames=6))


def test_every_link_and_joint_is_a_frame_in_a_documented_order():
    model = dynamics.load_urdf(erd("anymal_c_simple_description/urdf/anymal.urdf"), floating_base=True,
                               strict_inertia=False)
    names = model.frame_names
    assert names[0] == "root_joint" and names[1] == "base"
    # ANYmal names a link and a joint LF_HAA: the link keeps the name, the joint is joint:LF_HAA and it comes
    # just before its child link, whose frame it shares
    assert "LF_HAA" in names and "joint:LF_HAA" in names
    k = model.frame_index("joint:LF_HAA")
    assert names[k + 1] == "LF_HIP" and model.frames["joint:LF_HAA"][0] == model.frames["LF_HIP"][0]
    assert model.frame_index("LF_HAA") == names.index("LF_HAA")
    from lxml import etree

    root = etree.parse(erd("anymal_c_simple_description/urdf/anymal.urdf")).getroot()
    urdf_names = [el.get("name") for el in root.findall("link")] + [el.get("name") for el in root.findall("joint")]
    assert len(names) == len(urdf_names) + 1  # + root_joint
    # pruned links (massless, nothing moving below) are frames too
    assert set(model.info["links_pruned"]) <= set(names)
