"""Planar and spherical joints (issue 20, section 1) beyond the dynamics and kinematics of random trees (those are
in tests/test_pinocchio.py and tests/test_kinematics_pinocchio.py, against Pinocchio with every joint type):

* the configuration manifold against Pinocchio: integrate, difference, neutral, and reorder to its joint order;
* simulations against an independent model of the same motion with 1-dof joints only (a spherical joint as a
  z-y-x gimbal of three revolute joints, a planar joint as two prismatic joints and a revolute one), and the
  energy of a free spherical pendulum;
* lock_joints against the full model's rows, the service and the CLI on a URDF with these joints;
* clear errors for bad input (a zero axis, a zero quaternion or (cos, sin), a locked value of the wrong size).
"""

import json

import numpy as np
import pinocchio as pin
import pytest

import dynamics
from robots import ALL_TYPES, random_state, random_urdf
from test_pinocchio import PinMap, pin_model

INERTIAL = ('<inertial><origin xyz="{c}" rpy="0.3 -0.2 0.1"/><mass value="{m}"/>'
            '<inertia ixx="0.04" ixy="0.003" ixz="-0.002" iyy="0.05" iyz="0.001" izz="0.03"/></inertial>')


def link(name, c="0 0 0", m=0.0):
    return f'<link name="{name}">{INERTIAL.format(c=c, m=m) if m else ""}</link>'


def joint(name, jtype, parent, child, xyz="0 0 0", rpy="0 0 0", axis=None):
    ax = f'<axis xyz="{axis}"/>' if axis is not None else ""
    return (f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/>{ax}</joint>')


def robot(*parts):
    return '<robot name="r">' + "".join(parts) + "</robot>"


BOB = dict(c="0.05 -0.03 -0.5", m=1.5)
BALL = robot(link("base"), link("bob", **BOB), joint("ball", "spherical", "base", "bob", "0 0 1", "0.2 0 0"))
GIMBAL = robot(link("base"), link("lz"), link("ly"), link("bob", **BOB),
               joint("z", "continuous", "base", "lz", "0 0 1", "0.2 0 0", "0 0 1"),
               joint("y", "continuous", "lz", "ly", axis="0 1 0"), joint("x", "continuous", "ly", "bob", axis="1 0 0"))
SLIDER_BODY = dict(c="0.1 0.05 0.2", m=2.0)
SLIDER = robot(link("base"), link("body", **SLIDER_BODY),
               joint("plane", "planar", "base", "body", "0.1 0.2 0.3", "0.1 0.4 -0.2", "0 2 0"))


@pytest.fixture(scope="module")
def tree():
    """A random tree with every joint type below a URDF floating joint, and Pinocchio's model of it."""
    rng = np.random.default_rng(11)
    text = random_urdf(rng, n_links=9, types=ALL_TYPES, floating_joint=True)
    model = dynamics.load_urdf(text)
    assert {"planar", "spherical", "floating"} <= set(model.joint_types)
    return model, pin_model(text, model)


def wrap_continuous(model, dv):
    """dv with each continuous joint's coordinate taken modulo 2 pi into [-pi, pi)."""
    dv = np.array(dv)
    for name, t in zip(model.joint_names, model.joint_types):
        if t == "continuous":
            k = model.v_slice(name).start
            dv[k] = (dv[k] + np.pi) % (2 * np.pi) - np.pi
    return dv


def test_integrate_difference_neutral_match_pinocchio(tree):
    model, pm = tree
    mp = PinMap(model, pm)
    rng = np.random.default_rng(12)
    for _ in range(4):
        (q, v, _), (q1, _, _) = random_state(model, rng, 2.0), random_state(model, rng)
        ours = dynamics.integrate(model, q, v, 0.8)
        # pin.difference compares on the manifold: q and -q are the same quaternion
        assert np.abs(pin.difference(pm, mp.q(ours), pin.integrate(pm, mp.q(q), mp.v(0.8 * v)))).max() < 1e-12
        d = dynamics.difference(model, q, q1)
        # a continuous joint's angle lives on the real line here (q1 - q0), on the circle in Pinocchio
        assert np.abs(wrap_continuous(model, d - mp.v_back(pin.difference(pm, mp.q(q), mp.q(q1))))).max() < 1e-12
        assert np.abs(pin.difference(pm, mp.q(dynamics.integrate(model, q, d)), mp.q(q1))).max() < 1e-12
    assert np.array_equal(mp.q(model.neutral()), pin.neutral(pm))  # the revolute limits [-2, 2] hold 0
    assert np.abs(dynamics.difference(model, q, q)).max() < 1e-15


def test_reorder_maps_pinocchio_configurations(tree):
    """Pinocchio's coordinates of each joint, the joints in a shuffled order, mapped back into ours."""
    model, pm = tree
    mp = PinMap(model, pm)
    rng = np.random.default_rng(13)
    names = list(rng.permutation(model.joint_names))
    q, v, _ = random_state(model, rng)
    qp, vp = mp.q(q), mp.v(v)
    ids = [pm.getJointId(n) for n in names]
    theirs_q = np.concatenate([qp[pm.joints[j].idx_q:pm.joints[j].idx_q + pm.joints[j].nq] for j in ids])
    theirs_v = np.concatenate([vp[pm.joints[j].idx_v:pm.joints[j].idx_v + pm.joints[j].nv] for j in ids])
    back = dynamics.reorder(model, theirs_q, names, kind="pinocchio_q")
    # the continuous joints' angles come back through atan2: compare (cos, sin), i.e. Pinocchio's q
    assert np.abs(mp.q(back) - qp).max() < 1e-15
    assert np.array_equal(dynamics.reorder(model, back, names, kind="pinocchio_q", inverse=True), theirs_q)
    assert np.array_equal(dynamics.reorder(model, theirs_v, names, kind="v"), v)


def run(model, q0, v0, duration=1.0, **kw):
    tr = dynamics.simulate(model, q0, v0, duration, rtol=1e-10, atol=1e-12, integrator="dop853", **kw)
    assert tr.report["status"] == "ok"
    return tr


def test_spherical_pendulum_moves_as_a_gimbal_and_keeps_its_energy():
    ball, gimbal = dynamics.load_urdf(BALL), dynamics.load_urdf(GIMBAL)
    assert (ball.nq, ball.nv, gimbal.nv) == (4, 3, 3)
    g0, gd0 = np.array([0.3, 0.4, -0.2]), np.array([1.0, 0.3, -0.5])
    # the same initial state: the gimbal's orientation as a quaternion, its body angular velocity J_local gd
    R0 = dynamics.frame_placement(gimbal, np.zeros(3), "bob")[:3, :3]  # the joint's placement
    R = R0.T @ dynamics.frame_placement(gimbal, g0, "bob")[:3, :3]
    w = dynamics.frame_jacobian(gimbal, g0, "bob", reference="local")[3:] @ gd0
    quat = pin.Quaternion(R).coeffs()  # x, y, z, w
    assert np.allclose(dynamics.frame_placement(ball, quat, "bob"), dynamics.frame_placement(gimbal, g0, "bob"),
                       atol=1e-15)
    a, b = run(ball, quat, w, sample_dt=0.25), run(gimbal, g0, gd0, sample_dt=0.25)
    for qa, va, qb, vb in zip(a.q, a.v, b.q, b.v):
        assert np.linalg.norm(qa) == pytest.approx(1.0, abs=1e-14)
        Ta, Tb = dynamics.frame_placement(ball, qa, "bob"), dynamics.frame_placement(gimbal, qb, "bob")
        assert np.abs(Ta - Tb).max() < 1e-8
        assert np.abs(dynamics.frame_velocity(ball, qa, va, "bob") - dynamics.frame_velocity(gimbal, qb, vb, "bob")
                      ).max() < 1e-8
    E = [dynamics.kinetic_energy(ball, q, v) + dynamics.potential_energy(ball, q) for q, v in zip(a.q, a.v)]
    assert np.ptp(E) < 1e-8 * max(1.0, abs(E[0])) and a.report["energy_drift"] < 1e-8


def test_planar_joint_moves_as_two_sliders_and_a_hinge():
    body = dynamics.load_urdf(SLIDER)
    assert (body.nq, body.nv) == (4, 3) and "normal to its axis" in body.warnings[0]
    # the plane's directions, read from the model's motion: x along u, y along w, theta about the axis
    T0 = dynamics.frame_placement(body, body.neutral(), "body")
    u = T0[:3, :3].T @ (dynamics.frame_placement(body, [1, 0, 1, 0], "body")[:3, 3] - T0[:3, 3])
    w = T0[:3, :3].T @ (dynamics.frame_placement(body, [0, 1, 1, 0], "body")[:3, 3] - T0[:3, 3])
    axis = np.array([0.0, 1.0, 0.0])
    assert abs(u @ u - 1) < 1e-15 and abs(u @ axis) < 1e-15 and np.allclose(np.cross(u, w), axis, atol=1e-15)
    def fmt(x):
        return " ".join(f"{c:.17g}" for c in x)

    chain = dynamics.load_urdf(robot(
        link("base"), link("sx"), link("sy"), link("body", **SLIDER_BODY),
        joint("x", "prismatic", "base", "sx", "0.1 0.2 0.3", "0.1 0.4 -0.2", fmt(u)),
        joint("y", "prismatic", "sx", "sy", axis=fmt(w)),
        joint("t", "continuous", "sy", "body", axis="0 1 0")))
    th, vb = 0.4, np.array([0.5, -0.2, 1.5])  # v in the body frame
    q0 = np.array([0.3, -0.1, np.cos(th), np.sin(th)])
    c, s = np.cos(th), np.sin(th)
    qc0, vc0 = np.array([0.3, -0.1, th]), np.array([c * vb[0] - s * vb[1], s * vb[0] + c * vb[1], vb[2]])
    a, b = run(body, q0, vb), run(chain, qc0, vc0)
    assert not np.allclose(a.q[-1], a.q[0])
    for qa, va, qb, vb_ in zip(a.q[::100], a.v[::100], b.q[::100], b.v[::100]):
        Ta, Tb = dynamics.frame_placement(body, qa, "body"), dynamics.frame_placement(chain, qb, "body")
        assert np.abs(Ta - Tb).max() < 1e-8 and np.abs(qa[2:] - (np.cos(qb[2]), np.sin(qb[2]))).max() < 1e-8


def test_lock_joints_of_spherical_and_planar_joints_keeps_the_other_rows(tree):
    model, _ = tree
    rng = np.random.default_rng(14)
    q, v, a = random_state(model, rng)
    names = [n for n, t in zip(model.joint_names, model.joint_types) if t in ("spherical", "planar")]
    locked = {n: q[model.q_slice(n)] for n in names}
    reduced = dynamics.lock_joints(model, locked)
    assert reduced.nv == model.nv - 3 * len(names) and reduced.summary()["locked_joints"].keys() == set(names)
    keep_q = np.concatenate([np.arange(model.nq)[model.q_slice(n)] for n in reduced.joint_names])
    keep_v = np.concatenate([np.arange(model.nv)[model.v_slice(n)] for n in reduced.joint_names])
    v[[k for k in range(model.nv) if k not in keep_v]] = 0.0  # held still
    a[[k for k in range(model.nv) if k not in keep_v]] = 0.0
    qr, vr, ar = q[keep_q], v[keep_v], a[keep_v]
    full_tau = dynamics.inverse_dynamics(model, q, v, a)
    assert np.abs(dynamics.inverse_dynamics(reduced, qr, vr, ar) - full_tau[keep_v]).max() < 1e-10 * np.abs(full_tau).max()
    M = dynamics.mass_matrix(model, q)
    assert np.abs(dynamics.mass_matrix(reduced, qr) - M[np.ix_(keep_v, keep_v)]).max() < 1e-10 * np.abs(M).max()
    assert np.abs(dynamics.forward_kinematics(reduced, qr) - dynamics.forward_kinematics(model, q)).max() < 1e-12
    # and the free joint locked too: no quaternion left, a fixed base
    base = dynamics.lock_joints(model, {**locked, "float": q[model.q_slice("float")]})
    assert base.nq == base.nv and not base.floating_base


@pytest.mark.parametrize("value, words", [
    ([0.1, 0.2, 0.3], "expected 4 finite numbers [qx, qy, qz, qw] (a spherical joint)"),
    ([0.0, 0.0, 0.0, 0.0], "the quaternion is zero"),
])
def test_bad_locked_spherical_value_is_named(value, words):
    with pytest.raises(dynamics.InputError, match=r"locked\['ball'\]") as e:
        dynamics.lock_joints(dynamics.load_urdf(BALL), {"ball": value})
    assert words in str(e.value)


def test_bad_locked_planar_value_is_named():
    body = dynamics.load_urdf(SLIDER)
    with pytest.raises(dynamics.InputError, match=r"\(cos theta, sin theta\) is zero"):
        dynamics.lock_joints(body, {"plane": [1.0, 2.0, 0.0, 0.0]})
    with pytest.raises(dynamics.InputError, match=r"expected 4 finite numbers \[x, y, cos theta, sin theta\]"):
        dynamics.lock_joints(body, {"plane": 0.3})


def test_zero_quaternion_or_cos_sin_in_q_is_named_by_every_path():
    ball, body = dynamics.load_urdf(BALL), dynamics.load_urdf(SLIDER)
    for model, q, words in ((ball, np.zeros(4), r"q: the quaternion q\[0:4\] of a spherical joint is zero"),
                            (body, np.array([0.1, 0.2, 0.0, 0.0]), r"q: \(cos theta, sin theta\) q\[2:4\] of the "
                                                                  r"planar joint 'plane' is zero")):
        zero = np.zeros(model.nv)
        for call in (lambda q: dynamics.inverse_dynamics(model, q, zero, zero),  # one state: the compiled checks
                     lambda q: dynamics.mass_matrix(model, np.array([q, q])),  # a batch
                     lambda q: dynamics.frame_placement(model, list(q), 0),  # a list: the general path
                     lambda q: dynamics.integrate(model, q, zero)):
            with pytest.raises(dynamics.InputError, match=words):
                call(q)
        with pytest.raises(dynamics.InputError, match=words.replace("q", "q1", 1).replace(r"q\[", r"q1\[")):
            dynamics.difference(model, model.neutral(), q)
        with pytest.raises(dynamics.InputError, match="q0: the"):
            dynamics.simulate(model, q, zero, 0.1)
    # not unit: normalised (the kernels), with a warning in simulate
    with pytest.warns(dynamics.SimulationWarning, match=r"\(cos theta, sin theta\) of joint 'plane' had norm 2"):
        tr = run(body, [0.1, 0.2, 2.0, 0.0], np.zeros(3), 0.01)
    assert np.array_equal(tr.q[0], [0.1, 0.2, 1.0, 0.0])


def test_a_planar_joint_with_a_zero_axis_is_refused():
    with pytest.raises(dynamics.URDFError, match="joint 'plane': joint axis is zero .a planar joint's axis is the "
                                                 "normal of its plane"):
        dynamics.load_urdf(SLIDER.replace('"0 2 0"', '"0 0 0"'))
    # a spherical joint has no axis: any <axis> is not read
    assert np.array_equal(dynamics.load_urdf(BALL.replace("</joint>", '<axis xyz="0 0 0"/></joint>')).axes, [[0, 0, 0]])
    # the planar warning says when Pinocchio's parser reads the joint otherwise (it always takes z)
    assert dynamics.load_urdf(SLIDER.replace('"0 2 0"', '"0 0 3"')).warnings == ()
    no_axis = dynamics.load_urdf(SLIDER.replace('<axis xyz="0 2 0"/>', ""))
    assert no_axis.warnings == ("joint 'plane': a planar joint moves in the plane normal to its axis (1, 0, 0) (the "
                                "URDF default is (1, 0, 0)); Pinocchio's URDF parser always takes z",)


def test_cli_info_and_check_show_the_joint_types(tmp_path, capsys):
    from dynamics.cli import main

    path = tmp_path / "mixed.urdf"
    path.write_text(robot(link("base"), link("body", **SLIDER_BODY), link("bob", **BOB),
                          joint("plane", "planar", "base", "body", axis="0 0 1"),
                          joint("ball", "spherical", "body", "bob", "0 0 -0.2")))
    assert main(["info", str(path), "--json"]) == 0
    joints = {j["name"]: j for j in json.loads(capsys.readouterr().out)["joints"]}
    assert joints["plane"]["type"] == "planar" and joints["plane"]["q"] == [0, 4] and joints["plane"]["v"] == [0, 3]
    assert joints["ball"]["type"] == "spherical" and joints["ball"]["q"] == [4, 8] and joints["ball"]["v"] == [3, 6]
    assert main(["check", str(path)]) == 0
    assert "ok: r loads (nq=8, nv=6, 0 warnings)" in capsys.readouterr().out


def test_service_serves_a_robot_with_planar_and_spherical_joints(tmp_path):
    from service_fixtures import in_process_app
    from test_service_scene import every_endpoint

    text = robot(link("base"), link("body", **SLIDER_BODY), link("bob", **BOB), link("tip", **BOB),
                 joint("plane", "planar", "base", "body", axis="0 0 1"),
                 joint("ball", "spherical", "body", "bob", "0 0 -0.2"),
                 joint("hinge", "revolute", "bob", "tip", "0 0 -0.5", axis="0 1 0"))
    model = dynamics.load_urdf(text)
    with in_process_app(tmp_path / "store") as c:
        r = c.post("/v1/robots", json={"urdf": text})
        assert r.status_code == 201, r.text
        rid = r.json()["id"]
        info = c.get(f"/v1/robots/{rid}").json()
        assert [(j["type"], j["nq"], j["nv"]) for j in info["joints"]] == [("planar", 4, 3), ("spherical", 4, 3),
                                                                           ("revolute", 1, 1)]
        assert info["summary"]["joint_types"] == {"planar": 1, "spherical": 1, "revolute": 1}
        rng = np.random.default_rng(15)
        every_endpoint(c, rid, model, rng, None, None)
        locked = {"ball": [0.1, 0.2, 0.3, 0.9], "plane": [0.5, -0.5, 0.0, 1.0]}
        every_endpoint(c, rid, dynamics.lock_joints(model, locked), rng, 3, locked)
        r = c.post(f"/v1/robots/{rid}/gravity-torques", json={"q": [0.0] * 9})
        assert r.status_code == 422 and "planar joint 'plane' is zero" in r.json()["detail"]
        r = c.post(f"/v1/robots/{rid}/gravity-torques", json={"q": [0.0], "locked": {**locked, "ball": [1, 2, 3]}})
        assert r.status_code == 422 and "expected 4 finite numbers [qx, qy, qz, qw]" in r.json()["detail"]
