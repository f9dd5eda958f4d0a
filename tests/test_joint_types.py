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
        assert np.abs(d - mp.v_back(pin.difference(pm, mp.q(q), mp.q(q1)))).max() < 1e-12
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
