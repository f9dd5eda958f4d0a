"""Forward sensitivities of simulations (``simulate(..., sensitivities=...)``) against central finite differences
of whole simulations (double pendulum, Panda under PD, the four-bar), the reported error bound against the
truth (a run at a far tighter tolerance), and the robot's right-hand-side Jacobian (Radau's Newton matrix)
against finite differences of the right-hand side.

Compile cost: every (method, problem type) pair compiles its solver once (~20 s from an empty cache), so the
tests share three: rk45 and radau on the PD-driven robot with sensitivities, rk45 on the four-bar with
sensitivities.  The finite-difference runs reuse those signatures (they ask for the cheapest sensitivity), but
for Panda's (plain rk45 runs: nine extra columns at rtol 1e-11 would cost more than that compilation).
"""

import os

import numpy as np
import pytest

import dynamics
from dynamics.errors import InputError
from dynamics.torques import PD, Table
from robots import OUR_ROBOTS, erd

TWO_R = os.path.join(OUR_ROBOTS, "planar_2r.urdf")
TIGHT = dict(rtol=1e-11, atol=1e-13, error_estimate="none", outputs=("q", "v"))


def final_state(tr):
    return np.concatenate([tr.q[-1], tr.v[-1]])


def fd_x0(model, q0, v0, duration, h, **kw):
    """Central differences of the final state in each of the 2 nv initial coordinates (whole simulations)."""
    nv = model.nv
    F = np.empty((2 * nv, 2 * nv))
    for k in range(2 * nv):
        dx = np.zeros(2 * nv)
        dx[k] = h
        a = dynamics.simulate(model, q0 + dx[:nv], v0 + dx[nv:], duration, **kw)
        b = dynamics.simulate(model, q0 - dx[:nv], v0 - dx[nv:], duration, **kw)
        F[:, k] = (final_state(a) - final_state(b)) / (2 * h)
    return F


@pytest.fixture(scope="module")
def two_r():
    model = dynamics.load_urdf(TWO_R)
    pd = PD([0.5, -0.3], 8.0, 0.5)  # a soft PD: the pendulum still swings
    return model, np.array([0.3, 0.2]), np.array([0.0, 1.5]), pd


def test_double_pendulum_x0_against_finite_differences(two_r):
    model, q0, v0, pd = two_r
    tr = dynamics.simulate(model, q0, v0, 1.0, torque=pd, integrator="rk45", rtol=1e-10, atol=1e-12,
                           sensitivities=True, error_estimate="none")
    assert tr.sensitivities.shape == (len(tr.t), 4, 4)
    assert tr.report["sensitivities"]["columns"] == ["q0[0]", "q0[1]", "v0[0]", "v0[1]"]
    np.testing.assert_array_equal(tr.sensitivities[0], np.eye(4))
    F = fd_x0(model, q0, v0, 1.0, 1e-5, torque=pd, integrator="rk45", sensitivities=("kd",), **TIGHT)
    S = tr.sensitivities[-1]
    assert np.abs(F).max() > 1.0  # the motion does amplify perturbations
    assert np.abs(S - F).max() <= 1e-6 * np.abs(F).max()


def test_reported_error_bound_holds(two_r):
    """The rerun's estimate of the error of S(T) against the truth (rtol 1e-12): within a factor of 10."""
    model, q0, v0, pd = two_r
    truth = dynamics.simulate(model, q0, v0, 1.0, torque=pd, integrator="rk45", sensitivities=True,
                              rtol=1e-12, atol=1e-14, error_estimate="none").sensitivities[-1]
    for rtol in (1e-6, 1e-8):
        tr = dynamics.simulate(model, q0, v0, 1.0, torque=pd, integrator="rk45", sensitivities=True, rtol=rtol,
                               atol=rtol * 1e-2)
        est = tr.report["sensitivities"]["error_estimate"]
        err = np.abs(tr.sensitivities[-1] - truth).max()
        assert err / 10 <= est <= 10 * err, (rtol, est, err)


def test_pd_parameters_against_finite_differences(two_r):
    """dx(T)/d kp and d q_target: central differences of simulations with the perturbed gains and targets."""
    model, q0, v0, pd = two_r
    tr = dynamics.simulate(model, q0, v0, 1.0, torque=pd, integrator="rk45", rtol=1e-10, atol=1e-12,
                           sensitivities=("kp", "q_target"), error_estimate="none")
    cols = tr.report["sensitivities"]["columns"]
    assert cols == ["kp[0]", "kp[1]", "q_target[0]", "q_target[1]"]
    h = 1e-5
    for c, name in enumerate(cols):
        i = int(name[-2])
        runs = []
        for sign in (1, -1):
            kp = np.full(2, 8.0)
            target = np.array([0.5, -0.3])
            (kp if name.startswith("kp") else target)[i] += sign * h
            runs.append(final_state(dynamics.simulate(model, q0, v0, 1.0, torque=PD(target, kp, 0.5),
                                                      integrator="rk45", sensitivities=("kd",), **TIGHT)))
        fd = (runs[0] - runs[1]) / (2 * h)
        assert np.abs(tr.sensitivities[-1][:, c] - fd).max() <= 1e-6 * max(1.0, np.abs(fd).max()), name


def test_radau_agrees_with_rk45(two_r):
    """The same sensitivities through Radau (block-diagonal Newton matrix) and its error bound."""
    model, q0, v0, pd = two_r
    ref = dynamics.simulate(model, q0, v0, 1.0, torque=pd, integrator="rk45", sensitivities=("x0", "kp"),
                            rtol=1e-12, atol=1e-14, error_estimate="none").sensitivities[-1]
    tr = dynamics.simulate(model, q0, v0, 1.0, torque=pd, integrator="radau", sensitivities=("x0", "kp"),
                           rtol=1e-7, atol=1e-9)
    err = np.abs(tr.sensitivities[-1] - ref).max()
    est = tr.report["sensitivities"]["error_estimate"]
    assert err <= 1e-4 * np.abs(ref).max()
    assert err / 10 <= est <= 10 * err, (est, err)


def test_panda_under_pd_against_finite_differences():
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")
    q0 = model.neutral() + 0.1
    target = q0 + np.linspace(-0.2, 0.2, model.nq)
    pd = PD(target, 200.0, 20.0, tau_ff=dynamics.gravity_torques(model, target))
    v0 = np.zeros(model.nv)
    tr = dynamics.simulate(model, q0, v0, 0.2, torque=pd, integrator="rk45", rtol=1e-9, atol=1e-11,
                           sensitivities=True, error_estimate="none", outputs=("q", "v"))
    S = tr.sensitivities[-1]
    h = 1e-5
    for k in (0, 3, model.nv + 1, model.nv + 5):  # a few columns: q0 and v0 of the shoulder and the elbow
        dx = np.zeros(2 * model.nv)
        dx[k] = h
        a, b = (dynamics.simulate(model, q0 + s * dx[:model.nv], v0 + s * dx[model.nv:], 0.2, torque=pd,
                                  integrator="rk45", **TIGHT) for s in (1, -1))  # plain runs: 9 columns cost more
        fd = (final_state(a) - final_state(b)) / (2 * h)
        assert np.abs(S[:, k] - fd).max() <= 1e-5 * max(1.0, np.abs(fd).max()), k


@pytest.mark.filterwarnings("ignore::dynamics.errors.SimulationWarning")  # the differences leave the loop by ~1e-5
def test_four_bar_against_finite_differences():
    """A constrained model (KKT right-hand side, finite-difference Jacobian inside the variational equations)."""
    model = dynamics.load_urdf(os.path.join(OUR_ROBOTS, "four_bar.urdf"))
    q0 = dynamics.assemble(model, np.array([0.2, 0.5, 1.5]), fixed=["theta1"])
    v0 = dynamics.project_velocity(model, q0, np.array([1.0, 0.0, 0.0]))
    tr = dynamics.simulate(model, q0, v0, 0.3, integrator="rk45", rtol=1e-10, atol=1e-12, sensitivities=True,
                           error_estimate="none")
    F = fd_x0(model, q0, v0, 0.3, 1e-5, integrator="rk45", sensitivities=("x0",), **TIGHT)
    assert np.abs(tr.sensitivities[-1] - F).max() <= 1e-5 * np.abs(F).max()


def test_refusals(two_r):
    model, q0, v0, pd = two_r
    sim = dynamics.simulate
    with pytest.raises(InputError, match="sensitivities: expected distinct names"):
        sim(model, q0, v0, 0.1, torque=pd, sensitivities=("x0", "gain"))
    with pytest.raises(InputError, match="sensitivities: expected distinct names"):
        sim(model, q0, v0, 0.1, sensitivities=("kp",))  # no PD: no kp
    with pytest.raises(InputError, match="sensitivities: expected True or a sequence"):
        sim(model, q0, v0, 0.1, sensitivities="x0")
    with pytest.raises(InputError, match="integrator='euler'"):
        sim(model, q0, v0, 0.1, integrator="euler", dt=1e-3, sensitivities=True)
    table = Table(np.linspace(0, 1, 300), np.zeros((300, 2)))  # 600 parameters
    with pytest.raises(InputError, match="dense"):
        sim(model, q0, v0, 0.1, torque=table, integrator="radau", sensitivities=("tau",))
    floating = dynamics.load_urdf(TWO_R, floating_base=True)  # a free joint: x0 and the gains, not q_target
    with pytest.raises(InputError, match="'q_target' is for models of 1-dof joints only"):
        sim(floating, floating.neutral(), np.zeros(floating.nv), 0.1, torque=PD(floating.neutral(), 1.0, 0.1),
            sensitivities=("x0", "q_target"))
