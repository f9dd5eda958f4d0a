"""Constrained dynamics against Pinocchio (issue 10, section 3).

* Point (3D) and weld (6D) closures on random trees (fixed and floating base) and on our Cassie-like leg
  against ``pin.constraintDynamics`` with RigidConstraintModel: accelerations, and multipliers against
  Pinocchio's ``lambda_c`` in the LOCAL_WORLD_ALIGNED reference (the same convention as ours).
* The 5-row hinge closure, which Pinocchio does not offer, against the KKT solution built from Pinocchio's M,
  C v + g, frame Jacobians and classical Jdot v.
* Mimic couplings: Panda's gripper and random trees with mimic joints against Pinocchio's reduced-coordinate
  mimic model (buildModelFromUrdf(..., mimic=True), crba and rnea), Talos' gripper against the KKT reference.

Each state closes its loop at random q (the anchors are placed where the bodies are) and projects a random v
onto the constraints, so every convention of the rows agrees on the accelerations.
"""

import os

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from robots import OUR_ROBOTS, erd, random_state, random_urdf
from test_pinocchio import PinMap

TOL = 1e-9  # relative to the largest entry (cond(M) of random trees reaches 1e4)


def rel(x, ref):
    return np.abs(np.asarray(x) - ref).max() / max(np.abs(ref).max(), 1.0)


def pin_solve(pm, mp, rcms, q, v, tau, mu=0.0):
    """Pinocchio's constrained accelerations (our order) and lambda_c."""
    cm, cd = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for c in rcms:
        cm.append(c)
        cd.append(c.createData())
    pd = pm.createData()
    pin.initConstraintDynamics(pm, pd, cm, cd)
    prox = pin.ProximalSettings(1e-14, mu, 1 if mu == 0 else 200)
    a = pin.constraintDynamics(pm, pd, mp.q(q), mp.v(v), mp.v(tau), cm, cd, prox)
    return mp.v_back(a), np.array(pd.lambda_c)


def pin_anchor(pm, frame, T):
    """(joint id, placement in that joint) of a pose T given in our frame named ``frame`` (a link)."""
    fr = pm.frames[pm.getFrameId(frame)]
    return fr.parentJoint, fr.placement * pin.SE3(T)


def closure(model, pm, kind, a_name, b_name, q, rng):
    """A point or weld declaration closed at q, and Pinocchio's RigidConstraintModel of it."""
    Ta, Tb = dynamics.frame_placement(model, q, a_name), dynamics.frame_placement(model, q, b_name)
    A = np.eye(4)
    if kind == "point":
        A[:3, 3] = rng.normal(scale=0.2, size=3)
        B = np.linalg.solve(Tb, Ta @ A)
        B[:3, :3] = np.eye(3)
        con = dynamics.PointConstraint(a_name, b_name, A[:3, 3], B[:3, 3])
        ct = pin.ContactType.CONTACT_3D
    else:
        A = np.linalg.solve(Ta, Tb)
        B = np.eye(4)
        con = dynamics.WeldConstraint(a_name, b_name, A)
        ct = pin.ContactType.CONTACT_6D
    ja, Pa = pin_anchor(pm, a_name, A)
    jb, Pb = pin_anchor(pm, b_name, B)
    return con, pin.RigidConstraintModel(ct, pm, ja, Pa, jb, Pb, pin.LOCAL_WORLD_ALIGNED)


def check_against_pinocchio(model, pm, rcms, q, rng, mu=0.0):
    mp = PinMap(model, pm)
    _, v, tau = random_state(model, rng)
    v = dynamics.project_velocity(model, q, v)
    assert np.abs(dynamics.constraint_jacobian(model, q) @ v).max() < 1e-12 * max(1, np.abs(v).max())
    a, lam = dynamics.constrained_forward_dynamics(model, q, v, tau)
    a_pin, lam_pin = pin_solve(pm, mp, rcms, q, v, tau, mu)
    assert rel(a, a_pin) < TOL, (a, a_pin)
    assert rel(lam, lam_pin) < TOL, (lam, lam_pin)
    return rel(a, a_pin), rel(lam, lam_pin)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("kind", ["point", "weld"])
def test_random_tree_closures_match_pinocchio(seed, kind):
    rng = np.random.default_rng(100 + seed)
    n = 10 if kind == "point" else 16  # a weld needs 6 joints between its links
    text = random_urdf(rng, n_links=n, types=("revolute", "continuous", "prismatic"), branching=0.3,
                       floating_joint=seed % 3 == 2)
    tree = dynamics.load_urdf(text)
    pm = pin.buildModelFromXML(text)
    q, _, _ = random_state(tree, rng)
    for _ in range(20):  # two links whose loop has enough joints for independent rows
        a_name, b_name = (f"l{k}" for k in rng.choice(np.arange(1, n), 2, replace=False))
        con, rcm = closure(tree, pm, kind, a_name, b_name, q, rng)
        J = dynamics.constraint_jacobian(dynamics.with_constraints(tree, [con], at=q), q)
        if np.linalg.matrix_rank(J) == con.rows:
            break
    else:
        pytest.fail("no pair of links with independent rows")
    model = dynamics.with_constraints(tree, [con], at=q)
    assert np.abs(dynamics.constraint_residual(model, q)).max() < 1e-12
    check_against_pinocchio(model, pm, [rcm], q, rng)


@pytest.mark.parametrize("floating", [False, True], ids=["fixed", "floating"])
def test_cassie_like_leg_matches_pinocchio(floating):
    path = os.path.join(OUR_ROBOTS, "cassie_like_leg.urdf")
    model = dynamics.load_urdf(path, floating_base=floating)
    assert model.info["constraints"] == {"count": 1, "rows": 3, "rank": 3, "mobility": model.nv - 3,
                                         "closed_near_assembly": True}
    pm = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer()) if floating else pin.buildModelFromUrdf(path)
    con = model.constraints[0]
    A, B = np.eye(4), np.eye(4)
    A[:3, 3], B[:3, 3] = con.point_a, con.point_b
    rcm = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, pm, *pin_anchor(pm, "rod", A),
                                   *pin_anchor(pm, "tarsus", B), pin.LOCAL_WORLD_ALIGNED)
    rng = np.random.default_rng(7)
    actuated = ["hip_roll", "hip_yaw", "hip_pitch", "knee", "toe"]
    for _ in range(3):
        guess = model.neutral()
        for name in actuated:
            guess[model.q_slice(name)] = rng.uniform(-0.4, 0.4)
        if floating:
            guess[:3] = rng.normal(size=3)
            quat = rng.normal(size=4)
            guess[3:7] = quat / np.linalg.norm(quat)
        q = dynamics.assemble(model, guess, fixed=actuated)
        assert np.abs(dynamics.constraint_residual(model, q)).max() < 1e-12
        check_against_pinocchio(model, pm, [rcm], q, rng)


def kkt_reference(pm, mp, q, v, tau, J, gamma):
    """a, lambda of M a + b = tau + J^T lambda, J a = -gamma from Pinocchio's M and b (minimum-norm lambda)."""
    pd = pm.createData()
    qp, vp = mp.q(q), mp.v(v)
    M = mp.M_back(pin.crba(pm, pd, qp))
    b = mp.v_back(pin.rnea(pm, pd, qp, vp, np.zeros(pm.nv)))
    nv, m = M.shape[0], J.shape[0]
    K = np.block([[M, -J.T], [J, np.zeros((m, m))]])
    sol = np.linalg.lstsq(K, np.concatenate([tau - b, -gamma]), rcond=1e-13)[0]
    a = sol[:nv]
    lam = np.linalg.pinv(J.T, rcond=1e-12) @ (M @ a + b - tau)
    return a, lam


@pytest.mark.parametrize("seed", range(4))
def test_revolute_closure_matches_kkt_from_pinocchio(seed):
    """The 5-row hinge: rows built from Pinocchio's frame Jacobians and classical accelerations at a = 0."""
    rng = np.random.default_rng(200 + seed)
    text = random_urdf(rng, n_links=10, types=("revolute", "continuous", "prismatic"), branching=0.5)
    tree = dynamics.load_urdf(text)
    pm = pin.buildModelFromXML(text)
    mp = PinMap(tree, pm)
    q, v, tau = random_state(tree, rng)
    a_name, b_name = "l9", "l4"
    Ta, Tb = dynamics.frame_placement(tree, q, a_name), dynamics.frame_placement(tree, q, b_name)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    pa = rng.normal(scale=0.2, size=3)
    x = Ta[:3, :3] @ pa + Ta[:3, 3]
    con = dynamics.RevoluteConstraint(a_name, b_name, axis, pa, Tb[:3, :3].T @ (x - Tb[:3, 3]),
                                      axis_b=Tb[:3, :3].T @ Ta[:3, :3] @ axis)
    model = dynamics.with_constraints(tree, [con])
    assert np.abs(dynamics.constraint_residual(model, q)).max() < 1e-12
    v = dynamics.project_velocity(model, q, v)
    a, lam = dynamics.constrained_forward_dynamics(model, q, v, tau)
    # Pinocchio's side: OP frames at the two anchors (anchor a carries the hinge basis t1, t2, axis)
    pm2 = pin.Model(pm)
    u = axis
    t1 = np.cross([1.0, 0, 0] if abs(u[0]) < 0.9 else [0, 1.0, 0], u)
    t1 /= np.linalg.norm(t1)
    Ra = np.column_stack([t1, np.cross(u, t1), u])
    ids = []
    for name, R, p in ((a_name, Ra, pa), (b_name, np.eye(3), con.point_b)):
        fr = pm.frames[pm.getFrameId(name)]
        ids.append(pm2.addFrame(pin.Frame(f"anchor_{name}", fr.parentJoint, pm.getFrameId(name),
                                          fr.placement * pin.SE3(R, np.array(p)), pin.OP_FRAME)))
    pd = pm2.createData()
    qp, vp = mp.q(q), mp.v(v)
    pin.forwardKinematics(pm2, pd, qp, vp, np.zeros(pm.nv))
    pin.updateFramePlacements(pm2, pd)
    JA = pin.computeFrameJacobian(pm2, pd, qp, ids[0], pin.LOCAL_WORLD_ALIGNED)[:, mp.v_perm]
    JB = pin.computeFrameJacobian(pm2, pd, qp, ids[1], pin.LOCAL_WORLD_ALIGNED)[:, mp.v_perm]
    pin.forwardKinematics(pm2, pd, qp, vp, np.zeros(pm.nv))
    accA = pin.getFrameClassicalAcceleration(pm2, pd, ids[0], pin.LOCAL_WORLD_ALIGNED).vector
    accB = pin.getFrameClassicalAcceleration(pm2, pd, ids[1], pin.LOCAL_WORLD_ALIGNED).vector
    wA = pin.getFrameVelocity(pm2, pd, ids[0], pin.LOCAL_WORLD_ALIGNED).angular
    wB = pin.getFrameVelocity(pm2, pd, ids[1], pin.LOCAL_WORLD_ALIGNED).angular
    T = pd.oMf[ids[0]].rotation[:, :2].T  # t1, t2 in the world
    J = np.vstack([JA[:3] - JB[:3], T @ (JA[3:] - JB[3:])])
    gamma = np.concatenate([accA[:3] - accB[:3],
                            [np.cross(wA, t) @ (wA - wB) + t @ (accA[3:] - accB[3:]) for t in T]])
    np.testing.assert_allclose(dynamics.constraint_jacobian(model, q), J, atol=1e-12)
    np.testing.assert_allclose(dynamics.constraint_bias(model, q, v), gamma, atol=1e-10 * max(1, np.abs(gamma).max()))
    a_ref, lam_ref = kkt_reference(pm, mp, q, v, tau, J, gamma)
    assert rel(a, a_ref) < TOL
    assert rel(lam, lam_ref) < TOL


def mimic_reference(path_or_text, model, q, v, tau):
    """Accelerations of the coupled system from Pinocchio's reduced mimic model (crba and rnea support it):
    M_r a_r = G^T tau - b_r, with tau zero at followers; returns our full a (followers: multiplier * leader)."""
    build = pin.buildModelFromXML if path_or_text.lstrip().startswith("<") else pin.buildModelFromUrdf
    pm = build(path_or_text, mimic=True)
    pd = pm.createData()
    follower = {c.follower: c for c in model.constraints}
    # our coordinates -> Pinocchio's (a mimic joint shares its leader's index)
    qp, vp, tp = np.zeros(pm.nq), np.zeros(pm.nv), np.zeros(pm.nv)
    for i in range(1, pm.njoints):
        name, j = pm.names[i], pm.joints[i]
        k = model.joint_index(name)
        if name in follower:
            tp[j.idx_v] += follower[name].multiplier * tau[model.v_index[k]]
            continue
        qp[j.idx_q], vp[j.idx_v] = q[model.q_index[k]], v[model.v_index[k]]
        tp[j.idx_v] += tau[model.v_index[k]]
    M = pin.crba(pm, pd, qp)
    M = np.triu(M) + np.triu(M, 1).T
    ap = np.linalg.solve(M, tp - pin.rnea(pm, pd, qp, vp, np.zeros(pm.nv)))
    a = np.empty(model.nv)
    for i in range(1, pm.njoints):
        name, j = pm.names[i], pm.joints[i]
        k = model.v_index[model.joint_index(name)]
        a[k] = follower[name].multiplier * ap[j.idx_v] if name in follower else ap[j.idx_v]
    return a


def coupled_state(model, rng):
    """A random state satisfying the couplings (followers set from their leaders)."""
    q, v, tau = random_state(model, rng)
    for c in model.constraints:
        f, l = model.joint_index(c.follower), model.joint_index(c.leader)
        q[model.q_index[f]] = c.multiplier * q[model.q_index[l]] + c.offset
        v[model.v_index[f]] = c.multiplier * v[model.v_index[l]]
    return q, v, tau


def test_panda_gripper_mimic_matches_pinocchio():
    path = erd("panda_description/urdf/panda.urdf")
    model = dynamics.load_urdf(path)
    assert model.constraints == (dynamics.JointCoupling("panda_finger_joint2", "panda_finger_joint1", 1.0, 0.0),)
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, v, tau = coupled_state(model, rng)
        a, lam = dynamics.constrained_forward_dynamics(model, q, v, tau)
        assert rel(a, mimic_reference(path, model, q, v, tau)) < TOL
        # the coupling's force is what the follower needs beyond its own torque: M a + b - tau at the follower
        f = model.v_index[model.joint_index("panda_finger_joint2")]
        resid = dynamics.inverse_dynamics(model, q, v, a) - tau
        assert abs(lam[0] - resid[f]) < 1e-10 * max(1, abs(resid[f]))


def mimic_urdf(rng):
    """A random tree whose joints j3 and j6 mimic j1 and j2 (multipliers and offsets random)."""
    text = random_urdf(rng, n_links=8, types=("revolute", "prismatic"), branching=0.4)
    for follower, leader in (("j3", "j1"), ("j6", "j2")):
        k, off = rng.uniform(-2, 2), rng.uniform(-0.3, 0.3)
        head = f'<joint name="{follower}"'
        start = text.index(head)
        end = text.index("</joint>", start)
        text = text[:end] + f'<mimic joint="{leader}" multiplier="{k:.17g}" offset="{off:.17g}"/>' + text[end:]
    return text


@pytest.mark.parametrize("seed", range(3))
def test_random_tree_mimic_matches_pinocchio(seed):
    rng = np.random.default_rng(300 + seed)
    text = mimic_urdf(rng)
    model = dynamics.load_urdf(text)
    assert len(model.constraints) == 2
    q, v, tau = coupled_state(model, rng)
    assert np.abs(dynamics.constraint_residual(model, q)).max() < 1e-12
    a, _ = dynamics.constrained_forward_dynamics(model, q, v, tau)
    assert rel(a, mimic_reference(text, model, q, v, tau)) < TOL


def test_talos_gripper_mimic_matches_kkt_reference():
    path = erd("talos_data/robots/talos_full_v2.urdf")
    model = dynamics.load_urdf(path, strict_inertia=False)
    assert len(model.constraints) == 12
    pm = pin.buildModelFromUrdf(path)  # the open tree (mimic=False); rows of the couplings are written out
    mp = PinMap(model, pm)
    rng = np.random.default_rng(5)
    q, v, tau = coupled_state(model, rng)
    J = np.zeros((len(model.constraints), model.nv))
    for r, c in enumerate(model.constraints):
        J[r, model.v_slice(c.follower)] = 1.0
        J[r, model.v_slice(c.leader)] -= c.multiplier
    a, lam = dynamics.constrained_forward_dynamics(model, q, v, tau)
    a_ref, lam_ref = kkt_reference(pm, mp, q, v, tau, J, np.zeros(len(J)))
    assert rel(a, a_ref) < TOL and rel(lam, lam_ref) < TOL
