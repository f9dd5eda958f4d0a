"""What a simulation tells its user: accuracy warnings, the energy-balance scale, the progress bar,
Trajectory.plot and dynamics.work_precision."""

import os
from types import SimpleNamespace

import numpy as np
import pytest

import dynamics
from dynamics.simulation import report as R
from dynamics.torques import PD

ROBOTS = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "robots")
Q0 = np.array([np.pi / 2, np.pi / 4])


@pytest.fixture(scope="module")
def arm():
    return dynamics.load_urdf(os.path.join(ROBOTS, "planar_2r.urdf"))


def test_order_one_error_estimate_warns_but_status_stays_ok(arm):
    # rk4 at a step 100x too coarse (yet stable: dt * rho ~ 0.7) for the chaotic 2R arm: it finishes, but the
    # final state is wrong
    tr = dynamics.simulate(arm, Q0, [0, 0], 3.0, integrator="rk4", dt=0.15)
    ref = dynamics.simulate(arm, Q0, [0, 0], 3.0, rtol=1e-11, atol=1e-12, error_estimate="none")
    true = max(dynamics.simulation.state_error(arm, tr.q[-1], tr.v[-1], ref.q[-1], ref.v[-1]))
    assert tr.report["status"] == "ok"
    assert true > 0.1 and tr.report["error_estimate"] > 0.1
    assert any("of order one" in w for w in tr.report["warnings"])
    fine = dynamics.simulate(arm, Q0, [0, 0], 0.5, integrator="rk4", dt=1e-3)
    assert not any("error_estimate" in w for w in fine.report["warnings"])


def test_estimate_far_above_tolerance_warns():
    s = SimpleNamespace(fixed=False, rtol=1e-6, atol=1e-8)
    for est, expect in ((1e-7, None), (5e-3, "times the asked tolerance"), (2.0, "of order one")):
        warnings = []
        R.accuracy_warnings(s, {"error_estimate": est}, np.array([0.3, 0.2]), np.array([0.5, -0.1]), warnings)
        assert (expect is None and warnings == []) or (len(warnings) == 1 and expect in warnings[0])


def test_still_robot_reports_no_energy_drift(arm):
    # held at q0 by PD plus exact gravity compensation: K, the range of U and the work are all ~0
    g = dynamics.gravity_torques(arm, Q0)
    tr = dynamics.simulate(arm, Q0, [0, 0], 1.0, torque=PD(Q0, 500.0, 50.0, tau_ff=g))
    r = tr.report
    assert np.abs(tr.q - Q0).max() < 1e-9
    residual = abs(r["energy_final"] - r["energy_initial"] - r["work_torque"] - r["work_passive"])
    assert residual < 1e-9
    # the old scale (K, range of U, work) is ~1e-12 J here, so residual / scale was noise over noise
    mass_size_g = 2 * 12.456 * (1.0 + 0.773) * 9.81  # m L g of this arm, within a factor 2
    assert mass_size_g / 2 < r["energy_scale"] < 2 * mass_size_g
    assert r["energy_drift"] < 1e-12 and r["energy_drift"] == pytest.approx(residual / r["energy_scale"])


def test_progress_callback_and_switches(arm, capsys):
    seen = []
    tr = dynamics.simulate(arm, Q0, [0, 0], 2.0, progress=lambda t, total: seen.append((t, total)))
    assert seen and seen[-1] == (2.0, 2.0) and all(b[0] >= a[0] for a, b in zip(seen, seen[1:]))
    quiet = dynamics.simulate(arm, Q0, [0, 0], 2.0, progress=False)
    assert np.array_equal(quiet.q, tr.q)  # the watcher does not change the numbers
    dynamics.simulate(arm, Q0, [0, 0], 0.5, progress=True)
    assert "simulated" in capsys.readouterr().err  # tqdm's bar on stderr
    with pytest.raises(dynamics.InputError, match="progress"):
        dynamics.simulate(arm, Q0, [0, 0], 0.5, progress="yes")


def test_trajectory_plot(arm, tmp_path):
    pytest.importorskip("matplotlib")
    tr = dynamics.simulate(arm, Q0, [0, 0], 0.5, sample_dt=0.01)
    fig = tr.plot(tmp_path / "run.png", joint_names=arm.joint_names)
    assert len(fig.axes) == 3 and "status ok" in fig._suptitle.get_text()
    assert (tmp_path / "run.png").stat().st_size > 1000
    line = fig.axes[0].lines[1]
    assert np.allclose(line.get_ydata(), tr.q[:, 1])


def test_work_precision_table_and_figure(arm, tmp_path):
    pytest.importorskip("matplotlib")
    wp = dynamics.work_precision(arm, Q0, [0, 0], 0.5, integrators=("rk45", "rk4"), tolerances=(1e-4, 1e-8),
                                 dts=(1e-2, 5e-3), repeat=1, plot=tmp_path / "wp.png")
    rows = {(r["integrator"], r["tolerance"] or r["dt"]): r for r in wp.rows}
    assert len(rows) == 4 and all(r["status"] == "ok" and r["rhs_evals"] > 0 for r in wp.rows)
    assert rows[("rk45", 1e-8)]["error"] < rows[("rk45", 1e-4)]["error"] / 100
    # rk4 is fourth order: halving dt divides the error by ~16
    assert 8 < rows[("rk4", 1e-2)]["error"] / rows[("rk4", 5e-3)]["error"] < 32
    # the error column is the distance to an independent tight run
    ref = dynamics.simulate(arm, Q0, [0, 0], 0.5, integrator="radau", rtol=1e-12, atol=1e-12, error_estimate="none")
    tr = dynamics.simulate(arm, Q0, [0, 0], 0.5, integrator="rk45", rtol=1e-4, atol=1e-4, error_estimate="none")
    err = max(dynamics.simulation.state_error(arm, tr.q[-1], tr.v[-1], ref.q[-1], ref.v[-1]))
    assert rows[("rk45", 1e-4)]["error"] == pytest.approx(err, rel=1e-3)
    assert len(wp.figure.axes[0].lines) == 2 and (tmp_path / "wp.png").exists()
