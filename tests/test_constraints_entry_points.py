"""The unconstrained entry points on a constrained model (issue 10: "every function that should honour
constraints does so"): forward_dynamics returns the constrained accelerations, on its single-call fast path and
its batched path, equal to constrained_forward_dynamics (no Baumgarte); f_ext enters as J^T f_ext; the
RNEA-family functions keep their tree meaning (documented in the README), checked here against identities."""

import os
import time

import numpy as np
import pytest

import dynamics
from robots import OUR_ROBOTS, erd

LEG = os.path.join(OUR_ROBOTS, "cassie_like_leg.urdf")
FOUR_BAR = os.path.join(OUR_ROBOTS, "four_bar.urdf")
LEG_ACTUATED = ["hip_roll", "hip_yaw", "hip_pitch", "knee", "toe"]


def _leg_states(rng, B):
    leg = dynamics.load_urdf(LEG)
    Q = np.array([dynamics.assemble(leg, leg.neutral() + rng.uniform(-0.1, 0.1, leg.nq), fixed=LEG_ACTUATED)
                  for _ in range(B)])
    V = dynamics.project_velocity(leg, Q, rng.normal(size=(B, leg.nv)))
    return leg, Q, V, rng.normal(size=(B, leg.nv))


def test_forward_dynamics_single_and_batched_equal_the_constrained_accelerations():
    leg, Q, V, T = _leg_states(np.random.default_rng(1), 4)
    a_ref, lam = dynamics.constrained_forward_dynamics(leg, Q, V, T)
    assert np.abs(lam).max() > 1e-3  # the loops carry load: the unconstrained ABA would differ
    assert np.array_equal(dynamics.forward_dynamics(leg, Q, V, T), a_ref)  # the batched path
    for b in range(len(Q)):  # the single-call path, float64 vectors
        a = dynamics.forward_dynamics(leg, Q[b], V[b], T[b])
        assert a.shape == (leg.nv,)
        assert np.array_equal(a, dynamics.constrained_forward_dynamics(leg, Q[b], V[b], T[b])[0])
    # the motion honours the loops: Phi_q a + Phi_q_dot v = 0, which the tree's ABA does not
    a = dynamics.forward_dynamics(leg, Q[0], V[0], T[0])
    J, g = dynamics.constraint_jacobian(leg, Q[0]), dynamics.constraint_bias(leg, Q[0], V[0])
    assert np.abs(J @ a + g).max() < 1e-8
    a_tree = np.linalg.solve(dynamics.mass_matrix(leg, Q[0]), T[0] - dynamics.bias_forces(leg, Q[0], V[0]))
    assert np.abs(J @ a_tree + g).max() > 1e-3


def test_forward_dynamics_on_a_gripper_coupling_and_the_four_bar():
    panda = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))
    assert any(isinstance(c, dynamics.JointCoupling) for c in panda.constraints)
    rng = np.random.default_rng(2)
    q = dynamics.assemble(panda, panda.neutral() + rng.uniform(0.0, 0.03, panda.nq),
                          fixed=[n for n in panda.joint_names if n != "panda_finger_joint2"])
    v = dynamics.project_velocity(panda, q, rng.normal(size=panda.nv))
    tau = rng.normal(size=panda.nv)
    a = dynamics.forward_dynamics(panda, q, v, tau)
    assert np.array_equal(a, dynamics.constrained_forward_dynamics(panda, q, v, tau)[0])
    i1, i2 = (panda.v_slice(n).start for n in ("panda_finger_joint1", "panda_finger_joint2"))
    assert abs(a[i1] - a[i2]) < 1e-10  # the fingers move together
    fb = dynamics.load_urdf(FOUR_BAR)
    q = dynamics.assemble(fb, [0.3, 0.5, 1.5], fixed=["theta1"])
    v = dynamics.project_velocity(fb, q, [1.0, 0.0, 0.0])
    tau = np.array([0.2, 0.0, 0.0])
    assert np.array_equal(dynamics.forward_dynamics(fb, q, v, tau),
                          dynamics.constrained_forward_dynamics(fb, q, v, tau)[0])
    # explicit gravity takes the general path, same answer
    g = np.array([0.0, -9.81, 0.0])
    assert np.array_equal(dynamics.forward_dynamics(fb, q, v, tau, gravity=g),
                          dynamics.constrained_forward_dynamics(fb, q, v, tau, gravity=g)[0])


def test_external_forces_enter_as_their_generalised_force():
    leg, Q, V, T = _leg_states(np.random.default_rng(3), 2)
    F = np.random.default_rng(4).normal(size=(2, leg.nbodies, 6))
    a = dynamics.forward_dynamics(leg, Q, V, T, f_ext=F)
    # J^T f_ext independently: tau of the RNEA without and with the forces
    JtF = (dynamics.inverse_dynamics(leg, Q, V, np.zeros((2, leg.nv)))
           - dynamics.inverse_dynamics(leg, Q, V, np.zeros((2, leg.nv)), f_ext=F))
    a_ref, _ = dynamics.constrained_forward_dynamics(leg, Q, V, T + JtF)
    assert np.abs(a - a_ref).max() < 1e-12
    assert np.abs(a - dynamics.forward_dynamics(leg, Q, V, T)).max() > 1e-6


def test_inverse_dynamics_keeps_its_tree_meaning():
    """inverse_dynamics on a constrained model is M a + C v + g of the tree (the loops cut): for a constrained
    motion it equals tau + Phi_q^T lam, the joint torques plus what the loops carry."""
    leg, Q, V, T = _leg_states(np.random.default_rng(5), 1)
    a, lam = dynamics.constrained_forward_dynamics(leg, Q[0], V[0], T[0])
    J = dynamics.constraint_jacobian(leg, Q[0])
    tau_tree = dynamics.inverse_dynamics(leg, Q[0], V[0], a)
    assert np.abs(tau_tree - (T[0] + J.T @ lam)).max() < 1e-9
    # the torques of the actuated joints alone come from constrained_inverse_dynamics
    tau = dynamics.constrained_inverse_dynamics(leg, Q[0], V[0], a, actuated=LEG_ACTUATED + ["rod_pitch"])
    assert np.abs(dynamics.forward_dynamics(leg, Q[0], V[0], tau) - a).max() < 1e-8


def test_bad_input_on_a_constrained_model_names_the_argument():
    fb = dynamics.load_urdf(FOUR_BAR)
    with pytest.raises(dynamics.InputError, match="tau"):
        dynamics.forward_dynamics(fb, np.zeros(3), np.zeros(3), np.zeros(2))
    with pytest.raises(dynamics.InputError, match="q"):
        dynamics.forward_dynamics(fb, np.zeros(4), np.zeros(3), np.zeros(3))


def test_assemble_of_a_batch_stops_at_the_deadline():
    fb = dynamics.load_urdf(FOUR_BAR)
    with dynamics.parallel.deadline(time.monotonic() - 1.0):
        with pytest.raises(dynamics.DeadlineExceeded):
            dynamics.assemble(fb, [[0.3, 0.5, 1.5]] * 3, fixed=["theta1"])
    assert dynamics.assemble(fb, [[0.3, 0.5, 1.5]] * 3, fixed=["theta1"]).shape == (3, 3)
