"""``simulate`` on constrained models: the four-bar against SciPy on the lectures' closed form, the drift
report against the residual recomputed from the returned states, energy on a passive loop, the multipliers
per sample, Panda's coupled fingers, simulate_many.

Every run uses the default integrator ("auto"), so the suite compiles one constrained specialisation.
"""

import os

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dynamics
from robots import OUR_ROBOTS, erd
from test_constraints_four_bar import lectures

FOUR_BAR = os.path.join(OUR_ROBOTS, "four_bar.urdf")
TAU = np.array([0.3, 0.0, 0.0])  # a constant torque on the crank


@pytest.fixture(scope="module")
def four_bar():
    model = dynamics.load_urdf(FOUR_BAR)
    q0 = dynamics.assemble(model, np.array([0.2, 0.5, 1.5]), fixed=["theta1"])
    v0 = dynamics.project_velocity(model, q0, np.array([4.0, 0, 0]))
    return model, q0, v0


def residuals(model, q, v):
    """(max |phi|, max |Phi_q v|) over the samples, recomputed by the public functions."""
    phi = dynamics.constraint_residual(model, q)
    J = dynamics.constraint_jacobian(model, q)
    return float(np.abs(phi).max()), float(np.abs(np.einsum("bij,bj->bi", J, v)).max())


def test_ten_seconds_against_scipy_on_the_lectures_formula(four_bar):
    model, q0, v0 = four_bar
    tr = dynamics.simulate(model, q0, v0, 10.0, torque=TAU, rtol=1e-10, atol=1e-10, sample_dt=0.5)
    assert tr.report["status"] == "ok"
    ref = solve_ivp(lambda t, x: np.concatenate([x[3:], lectures(x[:3], x[3:], TAU)[0]]), (0, 10),
                    np.concatenate([q0, v0]), method="DOP853", rtol=1e-12, atol=1e-12, t_eval=tr.t)
    assert ref.success
    err = max(np.abs(tr.q - ref.y[:3].T).max(), np.abs(tr.v - ref.y[3:].T).max())
    assert err < 1e-6, err
    assert np.ptp(tr.q[:, 0]) > 1.0  # a large motion, not a twitch
    # the reported global error is honest: within 10x of the true error of the final state (or below 1e-8)
    final = max(np.abs(tr.q[-1] - ref.y[:3, -1]).max(), np.abs(tr.v[-1] - ref.y[3:, -1]).max())
    assert final < 10 * tr.report["error_estimate"] + 1e-8, (final, tr.report["error_estimate"])


@pytest.mark.parametrize("baumgarte", [(0.0, 0.0), None])
def test_drift_is_reported_honestly(four_bar, baumgarte):
    """constraint_drift is the largest residual over steps and samples: never below the residual recomputed at
    the samples, and close to it; Baumgarte (the default) holds it far below the unstabilised run's."""
    model, q0, v0 = four_bar
    tr = dynamics.simulate(model, q0, v0, 10.0, rtol=1e-6, atol=1e-8, baumgarte=baumgarte)
    d = tr.report["constraint_drift"]
    pos, vel = residuals(model, tr.q, tr.v)
    assert pos <= d["position"] * (1 + 1e-9) and vel <= d["velocity"] * (1 + 1e-9)
    assert d["position"] < 3 * pos and d["velocity"] < 3 * vel, (d, pos, vel)
    if baumgarte is None:
        assert d["baumgarte"] == [10.0, 10.0]
        free = dynamics.simulate(model, q0, v0, 10.0, rtol=1e-6, atol=1e-8, baumgarte=(0, 0), outputs=())
        assert d["position"] < free.report["constraint_drift"]["position"] / 10
        assert d["position"] < 1e-6


def test_projection_keeps_the_steps_on_the_manifold(four_bar):
    model, q0, v0 = four_bar
    tr = dynamics.simulate(model, q0, v0, 10.0, rtol=1e-6, atol=1e-8, baumgarte=(0, 0), project=True)
    free = dynamics.simulate(model, q0, v0, 10.0, rtol=1e-6, atol=1e-8, baumgarte=(0, 0), outputs=())
    d = tr.report["constraint_drift"]
    assert d["project"] is True
    assert d["position"] < free.report["constraint_drift"]["position"] / 10
    pos, _ = residuals(model, tr.q, tr.v)
    assert pos <= d["position"] * (1 + 1e-9)


def test_energy_of_a_passive_loop(four_bar):
    """No torque, no damping: E(T) = E(0) up to the integration error, and the report's energy_drift is the
    one recomputed from the returned states."""
    model, q0, v0 = four_bar
    assert not np.any(model.damping) and not np.any(model.friction)
    tr = dynamics.simulate(model, q0, v0, 10.0, rtol=1e-9, atol=1e-11)
    r = tr.report
    E = dynamics.kinetic_energy(model, tr.q, tr.v) + dynamics.potential_energy(model, tr.q)
    assert r["work_torque"] == 0.0 and r["work_passive"] == 0.0
    assert abs(E[-1] - E[0]) / r["energy_scale"] == pytest.approx(r["energy_drift"], rel=1e-6, abs=1e-15)
    assert np.abs(E - E[0]).max() / r["energy_scale"] == pytest.approx(r["energy_drift_max"], rel=1e-6, abs=1e-15)
    # the energy error is of the size of the reported state error (times the energy's sensitivity)
    sens = 10 * (np.abs(tr.v).max() + 9.81) * model.total_mass  # |dE/dq|, |dE/dv| bounds (J per rad, rad/s)
    assert np.abs(E - E[0]).max() < sens * r["error_estimate"] + 1e-12
    assert r["energy_drift_max"] < 1e-6


def test_lambda_per_sample_is_constrained_forward_dynamics(four_bar):
    model, q0, v0 = four_bar
    tr = dynamics.simulate(model, q0, v0, 2.0, torque=TAU, outputs=("q", "v", "lambda"), sample_dt=0.1)
    assert tr.lam.shape == (len(tr.t), 5)
    _, lam = dynamics.constrained_forward_dynamics(model, tr.q, tr.v, np.tile(TAU, (len(tr.t), 1)),
                                                   baumgarte=dynamics.constrained_dynamics.DEFAULT_BAUMGARTE)
    np.testing.assert_allclose(tr.lam, lam, rtol=0, atol=1e-10 * np.abs(lam).max())
    assert np.abs(tr.lam).max() > 1.0  # the loop carries real force (N)
    assert dynamics.simulate(model, q0, v0, 0.1, outputs=("q",)).lam is None


def test_panda_fingers_stay_coupled():
    model = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"))
    f1, f2 = (model.v_index[model.joint_index(n)] for n in ("panda_finger_joint1", "panda_finger_joint2"))
    q0 = model.neutral()
    q0[[f1, f2]] = 0.02
    v0 = np.zeros(model.nv)
    v0[:7] = 0.3
    v0[[f1, f2]] = 0.05
    tau = np.zeros(model.nv)
    tau[f1] = 5.0  # drive the leader only; the coupling moves the follower
    tr = dynamics.simulate(model, q0, v0, 0.5, torque=tau, outputs=("q", "v", "lambda"))
    assert tr.report["status"] == "ok"
    assert np.abs(tr.q[:, f2] - tr.q[:, f1]).max() < 1e-8
    assert np.abs(tr.v[:, f2] - tr.v[:, f1]).max() < 1e-8
    assert np.abs(tr.q[-1, f1] - q0[f1]) > 1e-3  # the fingers did move
    assert tr.report["constraint_drift"]["position"] < 1e-8


def test_simulate_many_on_a_constrained_model(four_bar):
    model, q0, v0 = four_bar
    q1 = dynamics.assemble(model, np.array([1.0, 0.5, 1.5]), fixed=["theta1"])
    Q0, V0 = np.array([q0, q1]), np.array([v0, np.zeros(3)])
    many = dynamics.simulate_many(model, Q0, V0, 1.0, sample_dt=0.1, outputs=("q", "lambda"))
    for k in range(2):
        one = dynamics.simulate(model, Q0[k], V0[k], 1.0, sample_dt=0.1, outputs=("q", "lambda"))
        np.testing.assert_array_equal(many.q[k], one.q)
        np.testing.assert_array_equal(many.lam[k], one.lam)
        assert many.reports[k]["constraint_drift"] == one.report["constraint_drift"]


def test_bad_arguments(four_bar):
    model, q0, v0 = four_bar
    with pytest.raises(dynamics.InputError, match="baumgarte"):
        dynamics.simulate(model, q0, v0, 0.1, baumgarte=(-1, 2))
    with pytest.raises(dynamics.InputError, match="project"):
        dynamics.simulate(model, q0, v0, 0.1, project="yes")
    with pytest.raises(dynamics.InputError, match="outputs"):
        dynamics.simulate(model, q0, v0, 0.1, outputs=("lam",))
