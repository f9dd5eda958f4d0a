"""Identities of constrained dynamics and bad input (issue 10, section 3).

Phi_q against finite differences of phi, Phi_q_dot v against the time derivative of Phi_q v, Baumgarte's
Phi_q a + Phi_q_dot v = -(2 alpha Phi_q v + beta^2 phi), lambda does no work on a consistent velocity,
constrained inverse then forward dynamics returns the motion, projection, and the errors of bad input.
"""

import os

import numpy as np
import pytest

import dynamics
from dynamics import _core
from dynamics.constraints import core_constraints
from robots import OUR_ROBOTS, random_state, random_urdf

LEG = os.path.join(OUR_ROBOTS, "cassie_like_leg.urdf")
FOUR_BAR = os.path.join(OUR_ROBOTS, "four_bar.urdf")


def random_loops(seed):
    """A random floating tree with a point, a weld, a hinge and a coupling (closed at a random q)."""
    rng = np.random.default_rng(seed)
    tree = dynamics.load_urdf(random_urdf(rng, n_links=20, types=("revolute", "prismatic"), branching=0.1),
                              floating_base=True)
    q, _, _ = random_state(tree, rng)
    Ta, Tb = dynamics.frame_placement(tree, q, "l13"), dynamics.frame_placement(tree, q, "l6")
    x = Ta[:3, 3] + Ta[:3, :3] @ [0.1, 0.0, 0.2]
    axis = np.array([0.3, -0.2, 0.9])
    cons = [dynamics.PointConstraint("l13", "l6", (0.1, 0.0, 0.2), Tb[:3, :3].T @ (x - Tb[:3, 3])),
            dynamics.WeldConstraint("l19", "l1"),
            dynamics.RevoluteConstraint("l13", "l6", axis, (0.1, 0.0, 0.2), Tb[:3, :3].T @ (x - Tb[:3, 3]),
                                        axis_b=Tb[:3, :3].T @ Ta[:3, :3] @ axis / np.linalg.norm(axis)),
            dynamics.JointCoupling("j9", "j10", -0.7, 0.1)]
    model = dynamics.with_constraints(tree, cons, at=q)
    return model, q, rng


@pytest.mark.parametrize("seed", range(2))
def test_jacobian_and_bias_against_finite_differences(seed):
    model, q, rng = random_loops(seed)
    q = q + 0.0  # off the manifold too: the point and coupling rows are exact everywhere
    _, v, _ = random_state(model, rng)
    eps = 1e-6
    J = dynamics.constraint_jacobian(model, q)
    # d/dt phi(q(t)) along q(t) = integrate(q, v t) equals J v on the manifold (weld/hinge rows: on it)
    dphi = (dynamics.constraint_residual(model, dynamics.integrate(model, q, v, eps))
            - dynamics.constraint_residual(model, dynamics.integrate(model, q, v, -eps))) / (2 * eps)
    np.testing.assert_allclose(J @ v, dphi, atol=1e-7 * max(1, np.abs(dphi).max()))
    # d/dt (J(q(t)) v) = Phi_q_dot v (v constant, a = 0)
    dJv = (dynamics.constraint_jacobian(model, dynamics.integrate(model, q, v, eps)) @ v
           - dynamics.constraint_jacobian(model, dynamics.integrate(model, q, v, -eps)) @ v) / (2 * eps)
    np.testing.assert_allclose(dynamics.constraint_bias(model, q, v), dJv, atol=1e-6 * max(1, np.abs(dJv).max()))


@pytest.mark.parametrize("seed", range(2))
def test_baumgarte_identity_and_no_work(seed):
    model, q0, rng = random_loops(seed)
    q, v, tau = random_state(model, rng)
    q = dynamics.integrate(model, q0, v, 1e-2)  # a little off the manifold: phi != 0
    alpha, beta = 5.0, 7.0
    a, lam = dynamics.constrained_forward_dynamics(model, q, v, tau, baumgarte=(alpha, beta))
    J, phi = dynamics.constraint_jacobian(model, q), dynamics.constraint_residual(model, q)
    lhs = J @ a + dynamics.constraint_bias(model, q, v)
    np.testing.assert_allclose(lhs, -(2 * alpha * J @ v + beta ** 2 * phi), atol=1e-9 * max(1, np.abs(lhs).max()))
    # the equations of motion hold with the multipliers
    np.testing.assert_allclose(dynamics.inverse_dynamics(model, q, v, a), tau + J.T @ lam,
                               atol=1e-9 * max(1, np.abs(tau).max(), np.abs(J.T @ lam).max()))
    # lambda does no work on a velocity the constraints allow
    vc = dynamics.project_velocity(model, q, v)
    assert np.abs(J @ vc).max() < 1e-11 * max(1, np.abs(v).max())
    assert abs(lam @ (J @ vc)) < 1e-9 * max(1, np.abs(lam).max() * np.abs(vc).max())
    # the projection is the closest velocity in the kinetic-energy metric: v - vc is M^-1 J^T mu
    M = dynamics.mass_matrix(model, q)
    mu = np.linalg.lstsq(J.T, M @ (v - vc), rcond=None)[0]
    np.testing.assert_allclose(J.T @ mu, M @ (v - vc), atol=1e-9 * max(1, np.abs(M @ v).max()))


def test_redundant_rows_give_unique_accelerations_and_minimum_norm_multipliers():
    """Two identical point closures: a is that of one closure, lambda splits evenly (minimum norm)."""
    leg = dynamics.load_urdf(LEG)
    twice = dynamics.with_constraints(leg, [leg.constraints[0]])
    assert twice.info["constraints"]["rows"] == 6 and twice.info["constraints"]["rank"] == 3
    rng = np.random.default_rng(4)
    q = dynamics.assemble(leg, leg.neutral() + 0.1, fixed=["hip_roll", "hip_yaw", "hip_pitch", "knee", "toe"])
    _, v, tau = random_state(leg, rng)
    v = dynamics.project_velocity(leg, q, v)
    a1, lam1 = dynamics.constrained_forward_dynamics(leg, q, v, tau)
    a2, lam2 = dynamics.constrained_forward_dynamics(twice, q, v, tau)
    np.testing.assert_allclose(a2, a1, atol=1e-10 * np.abs(a1).max())
    np.testing.assert_allclose(lam2, np.concatenate([lam1, lam1]) / 2, atol=1e-10 * np.abs(lam1).max())


def test_constrained_inverse_then_forward_returns_the_motion():
    leg = dynamics.load_urdf(LEG)
    actuated = ["hip_roll", "hip_yaw", "hip_pitch", "knee", "toe", "rod_pitch"]  # 6 = the mobility
    rng = np.random.default_rng(5)
    q = dynamics.assemble(leg, leg.neutral() + rng.uniform(-0.2, 0.2, leg.nq), fixed=actuated[:5])
    _, v, tau0 = random_state(leg, rng)
    v = dynamics.project_velocity(leg, q, v)
    a, _ = dynamics.constrained_forward_dynamics(leg, q, v, tau0)  # a motion the loop allows
    tau = dynamics.constrained_inverse_dynamics(leg, q, v, a, actuated=actuated)
    passive = [leg.v_index[leg.joint_index(n)] for n in leg.joint_names if n not in actuated]
    assert np.all(tau[passive] == 0.0)
    a2, _ = dynamics.constrained_forward_dynamics(leg, q, v, tau)
    np.testing.assert_allclose(a2, a, atol=1e-8 * max(1, np.abs(a).max()))
    # the four-bar: the crank alone drives it; a batch gives the same torques
    fb = dynamics.load_urdf(FOUR_BAR)
    qs = np.array([dynamics.assemble(fb, [c, 0.5, 1.5], fixed=["theta1"]) for c in (0.1, 1.0, 2.0)])
    vs = dynamics.project_velocity(fb, qs, np.tile([1.0, 0, 0], (3, 1)))
    A, _ = dynamics.constrained_forward_dynamics(fb, qs, vs, np.tile([0.7, 0, 0], (3, 1)))
    T = dynamics.constrained_inverse_dynamics(fb, qs, vs, A, actuated=["theta1"])
    np.testing.assert_allclose(T, np.tile([0.7, 0, 0], (3, 1)), atol=1e-10)


@pytest.mark.parametrize("robot", ["cassie_like_leg.urdf", "stewart_platform.urdf", "four_bar.urdf"])
def test_redundant_actuation_gives_the_minimum_norm_torques(robot):
    """Every joint actuated (more actuators than the mobility): tau is the minimum-norm solution of
    N^T tau = N^T (M a + C v + g), N an orthonormal basis of null(Phi_q) from numpy's SVD (an independent
    reference: LAPACK, not the core's Gram-Schmidt)."""
    model = dynamics.load_urdf(os.path.join(OUR_ROBOTS, robot))
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = dynamics.integrate(model, model.neutral(), rng.uniform(-0.3, 0.3, model.nv))
        v, tau0 = rng.normal(size=model.nv), rng.normal(size=model.nv)
        a, _ = dynamics.constrained_forward_dynamics(model, q, v, tau0)
        tau = dynamics.constrained_inverse_dynamics(model, q, v, a, actuated=list(model.joint_names))
        J = dynamics.constraint_jacobian(model, q)
        _, sv, Vt = np.linalg.svd(J)
        N = Vt[int(np.sum(sv > 1e-9 * sv[0])):].T
        f = dynamics.inverse_dynamics(model, q, v, a)
        ref = np.linalg.pinv(N.T) @ (N.T @ f)
        np.testing.assert_allclose(tau, ref, rtol=0, atol=1e-11 * max(1.0, np.abs(f).max()))


def test_inverse_dynamics_errors():
    leg = dynamics.load_urdf(LEG)
    q = dynamics.assemble(leg, leg.neutral() + 0.1, fixed=["hip_roll", "hip_yaw", "hip_pitch", "knee", "toe"])
    v = np.zeros(leg.nv)
    a, _ = dynamics.constrained_forward_dynamics(leg, q, v, np.ones(leg.nv))
    with pytest.raises(dynamics.InputError, match="cannot produce this motion"):
        dynamics.constrained_inverse_dynamics(leg, q, v, a, actuated=["knee"])
    with pytest.raises(dynamics.InputError, match="violates the constraints"):
        dynamics.constrained_inverse_dynamics(leg, q, v, a + 1.0, actuated=list(leg.joint_names))
    with pytest.raises(dynamics.InputError, match="no joint named 'kne'"):
        dynamics.constrained_inverse_dynamics(leg, q, v, a, actuated=["kne"])


def test_drift_reports_position_and_velocity_residuals():
    """The core's drift (a simulation's constraint_drift) against the public residual and Jacobian."""
    fb = dynamics.load_urdf(FOUR_BAR)
    q, v = np.array([0.3, 1.0, 1.2]), np.array([0.5, -0.2, 0.3])
    pos, vel = _core.constraint_drift(fb.core, core_constraints(fb), q, v)
    assert pos == np.abs(dynamics.constraint_residual(fb, q)).max()
    assert vel == pytest.approx(np.abs(dynamics.constraint_jacobian(fb, q) @ v).max(), rel=1e-14)


def test_position_projection_returns_to_the_manifold():
    """The simulation's projection after a step (the core's): a perturbed leg configuration back onto phi = 0."""
    leg = dynamics.load_urdf(LEG, floating_base=True)
    rng = np.random.default_rng(8)
    q = dynamics.assemble(leg, leg.neutral(), fixed=["root_joint", "hip_roll", "hip_yaw", "hip_pitch", "knee", "toe"])
    q_step = dynamics.integrate(leg, q, rng.normal(size=leg.nv), 1e-3)  # a step's drift
    assert np.abs(dynamics.constraint_residual(leg, q_step)).max() > 1e-5
    out = np.empty(leg.nq)
    err = _core.project_position(leg.core, core_constraints(leg), q_step, 1e-12, 10, out)
    assert err <= 1e-12 and err == np.abs(dynamics.constraint_residual(leg, out)).max()
    assert np.abs(out - q_step).max() < 1e-2  # a small correction


# -- bad input ---------------------------------------------------------------------------------------------------

def test_unknown_frames_and_joints_list_the_closest_names():
    fb = dynamics.load_urdf(FOUR_BAR)
    with pytest.raises(dynamics.InputError, match=r"no frame named 'link4'.*link"):
        dynamics.with_constraints(fb, [dynamics.PointConstraint("link2", "link4")])
    with pytest.raises(dynamics.InputError, match=r"no joint named 'theta3'.*theta"):
        dynamics.with_constraints(fb, [dynamics.JointCoupling("theta3", "theta1")])
    with pytest.raises(dynamics.InputError, match="cannot follow itself"):
        dynamics.JointCoupling("theta1", "theta1")
    with pytest.raises(dynamics.InputError, match="axis is zero"):
        dynamics.RevoluteConstraint("link2", "link3", (0, 0, 0))
    with pytest.raises(dynamics.InputError, match="expected PointConstraint"):
        dynamics.with_constraints(fb, ["link2"])


def test_over_constrained_mechanisms_are_refused_with_the_rank():
    fb = dynamics.load_urdf(FOUR_BAR)
    with pytest.raises(dynamics.InputError, match=r"over-constrained.*rank 3 = nv = 3"):
        dynamics.with_constraints(fb, [dynamics.JointCoupling("theta2", "theta1", 2.0)])
    # locking the crank leaves a rigid structure
    with pytest.raises(dynamics.InputError, match=r"over-constrained.*rank 2 = nv = 2"):
        dynamics.lock_joints(fb, {"theta1": 0.3})


def test_lock_joints_keeps_constraints_consistent():
    """Locking two hip joints of the leg keeps its loop; the reduced model moves like the full one with those
    joints held by couplings to a constant (multiplier 0)."""
    leg = dynamics.load_urdf(LEG)
    held = {"hip_roll": 0.1, "hip_yaw": -0.2}
    locked = dynamics.lock_joints(leg, held)
    assert locked.constraints == leg.constraints and locked.info["constraints"]["mobility"] == 4
    pinned = dynamics.with_constraints(leg, [dynamics.JointCoupling(n, "knee", 0.0, x) for n, x in held.items()])
    q = dynamics.assemble(pinned, leg.neutral() + 0.05, fixed=["hip_pitch", "knee", "toe"])
    keep = [k for k, n in enumerate(leg.joint_names) if n not in held]
    np.testing.assert_allclose(dynamics.constraint_residual(locked, q[keep]), 0.0, atol=1e-12)
    rng = np.random.default_rng(0)
    _, v, tau = random_state(leg, rng)
    v = dynamics.project_velocity(pinned, q, v)
    a_full, _ = dynamics.constrained_forward_dynamics(pinned, q, v, tau)
    a_locked, _ = dynamics.constrained_forward_dynamics(locked, q[keep], v[keep], tau[keep])
    np.testing.assert_allclose(a_locked, a_full[keep], atol=1e-9 * np.abs(a_full).max())
    # couplings: one locked side is refused with the value to lock the other at
    arm = dynamics.with_constraints(dynamics.load_urdf(os.path.join(OUR_ROBOTS, "planar_3r.urdf")),
                                    [dynamics.JointCoupling("joint3", "joint2", 2.0, 0.1)])
    with pytest.raises(dynamics.InputError, match=r"lock 'joint3' at 0.7"):
        dynamics.lock_joints(arm, {"joint2": 0.3})
    both = dynamics.lock_joints(arm, {"joint2": 0.3, "joint3": 0.7})
    assert both.constraints == ()
    with pytest.raises(dynamics.InputError, match="must be locked at 0.7"):
        dynamics.lock_joints(arm, {"joint2": 0.3, "joint3": 0.5})


def test_loops_that_cannot_close():
    fb = dynamics.load_urdf(FOUR_BAR)
    with pytest.raises(dynamics.InputError, match=r"cannot close.*max \|phi\| = .* > tol"):
        # the rocker is 0.3 m, the ground 0.4 m: the coupler's tip cannot reach its end from everywhere
        dynamics.assemble(fb, [0.0, 0.0, 0.0], fixed={"theta1": 0.0, "theta2": 0.0})
    # a rocker pin 2 m out: 2 m against 0.1 + 0.35 + 0.4 m for the rest of the loop, it can never close; refused
    # at load since issue 25 (it used to load and fail in assemble)
    text = open(FOUR_BAR).read().replace('<link_b name="link3" xyz="0.3 0 0"/>', '<link_b name="link3" xyz="2.0 0 0"/>')
    with pytest.raises(dynamics.URDFError, match=r"cannot close in any configuration: the segment of 2 m .* 0\.85 m"):
        dynamics.load_urdf(text)


def test_bad_urdf_loops_and_mimics():
    head = open(FOUR_BAR).read().split("<!-- the closing pin")[0]
    cases = {
        '<loop name="x" type="prismatic"><link_a name="link2"/><link_b name="link3"/></loop>': "expected 'point'",
        '<loop name="x" type="point"><link_a name="link2"/></loop>': "missing <link_b",
        '<loop name="x" type="point"><link_a name="link2"/><link_b name="lnk3"/></loop>': "unknown link 'lnk3'",
        '<loop name="x" type="revolute"><link_a name="link2"/><link_b name="link3"/></loop>': "needs <axis",
        '<loop name="x" type="point"><link_a name="link2" xyz="1 nan 0"/><link_b name="link3"/></loop>': "finite",
    }
    for loop, message in cases.items():
        with pytest.raises(dynamics.URDFError, match=message):
            dynamics.load_urdf(head + loop + "</robot>")
    mimic = head.replace('<axis xyz="0 0 1"/>\n  </joint>\n  <link name="link2">',
                         '<axis xyz="0 0 1"/>\n    <mimic joint="theta7"/>\n  </joint>\n  <link name="link2">')
    with pytest.raises(dynamics.URDFError, match=r"mimic joint='theta7'.*closest.*theta"):
        dynamics.load_urdf(mimic + "</robot>")
    assert dynamics.load_urdf(mimic + "</robot>", mimic="independent").constraints == ()
    with pytest.raises(dynamics.URDFError, match="mimic: expected 'coupling' or 'independent'"):
        dynamics.load_urdf(FOUR_BAR, mimic="reduced")
