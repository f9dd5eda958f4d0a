"""The models of the four-bar simulation benchmark (benchmarks/four_bar_sim.py) are the four-bar of
robots/four_bar.urdf: the MJCF written for MuJoCo has our mass matrix, bias forces and closure; the closed form
the reference integrates and the Pinocchio right-hand side give our constrained accelerations (Baumgarte
terms included, off the manifold).  Fast: no simulation is run.
"""

import os

import mujoco
import numpy as np
import pytest

import dynamics
from benchmarks import four_bar_sim as bench
from robots import OUR_ROBOTS
from test_constraints_four_bar import lectures


@pytest.fixture(scope="module")
def model():
    return dynamics.load_urdf(os.path.join(OUR_ROBOTS, "four_bar.urdf"))


def test_mjcf_is_our_four_bar(model):
    m = bench.mujoco_model(bench.mjcf(), "RK4", 1e-3, *bench.MJ_DEFAULT)
    d = mujoco.MjData(m)
    assert (m.nq, m.nv, m.neq) == (3, 3, 1)
    assert [m.joint(k).name for k in range(m.njnt)] == list(model.joint_names)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q, v = rng.uniform(-np.pi, np.pi, 3), rng.normal(size=3) * 3  # open loop: the residual is not zero
        d.qpos[:], d.qvel[:] = q, v
        mujoco.mj_forward(m, d)
        M = np.zeros((3, 3))
        mujoco.mj_fullM(m, d, M)
        np.testing.assert_allclose(M, dynamics.mass_matrix(model, q), rtol=0, atol=1e-14)
        np.testing.assert_allclose(d.qfrc_bias, dynamics.bias_forces(model, q, v), rtol=0, atol=1e-12)
        # connect rows: site1 - site2 in world axes = the hinge closure's point rows x_A - x_B
        np.testing.assert_allclose(d.efc_pos[:3], dynamics.constraint_residual(model, q)[:3], rtol=0, atol=1e-14)
        assert np.abs(d.efc_pos[:3]).max() > 1e-3


def test_closed_form_and_pinocchio_give_our_accelerations(model):
    rhs = bench.lectures_rhs(bench.four_bar_numbers())
    pin_rhs = bench.pinocchio_rhs(model)
    rng = np.random.default_rng(4)
    for _ in range(5):
        q = dynamics.assemble(model, np.array([rng.uniform(-np.pi, np.pi), 0.5, 1.5]), fixed=["theta1"])
        v = dynamics.project_velocity(model, q, rng.normal(size=3) * 3)
        a, _ = dynamics.constrained_forward_dynamics(model, q, v, np.zeros(3))
        scale = max(1.0, np.abs(a).max())
        np.testing.assert_allclose(rhs(0.0, np.r_[q, v])[3:], a, rtol=0, atol=1e-11 * scale)
        np.testing.assert_allclose(lectures(q, v, np.zeros(3))[0], a, rtol=0, atol=1e-11 * scale)
        # off the manifold the Baumgarte terms act: Pinocchio's Kp = beta^2, Kd = 2 alpha are ours (10, 10)
        qo, vo = q + rng.normal(size=3) * 1e-2, v + rng.normal(size=3) * 0.1
        ao, _ = dynamics.constrained_forward_dynamics(model, qo, vo, np.zeros(3), baumgarte=bench.BAUMGARTE)
        a_free, _ = dynamics.constrained_forward_dynamics(model, qo, vo, np.zeros(3))
        assert np.abs(ao - a_free).max() > 1e-2 * scale
        np.testing.assert_allclose(pin_rhs(0.0, np.r_[qo, vo])[3:], ao, rtol=0, atol=1e-9 * scale)
