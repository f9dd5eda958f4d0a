"""What testers found in simulate (issue 25): B8 a singular operational-space task, C10 report warnings through
Python's ``warnings``, D15 ``engine="processes"`` from a script without a ``__main__`` guard.  Also issue 24's
proof that the compiled loop runs with the GIL released."""

import os
import subprocess
import sys
import threading
import time
import warnings

import numpy as np
import pytest

import dynamics
from dynamics.torques import Target

from robots import OUR_ROBOTS

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def arm():
    return dynamics.load_urdf(os.path.join(OUR_ROBOTS, "planar_2r.urdf"))


def test_singular_task_says_singular_with_frame_and_condition(arm):
    # the planar 2R arm moves its tip in x and z only: the y row can never be reached (J M^-1 J^T singular)
    with pytest.raises(dynamics.InputError, match="singular, condition number") as e:
        dynamics.operational_space_inertia(arm, [0.5, 0.2], "tip", rows=[0, 1])
    cond = str(e.value).split("condition number")[1].split()[0].strip(",;:)")
    target = Target("tip", [1.0, 0.0, 1.0], kp=100.0, kd=20.0, rows=[0, 1])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", dynamics.SimulationWarning)
        tr = dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 0.1, torque=target, integrator="rk4", dt=1e-3)
    status = tr.report["status"]
    assert status.startswith("unstable") and "singular" in status and "'tip'" in status
    assert float(status.split("condition number")[1].split()[0].strip(",;:)")) == pytest.approx(float(cond), rel=1e-6)
    # a failed run returns at least its initial sample
    assert len(tr.t) >= 1 and tr.t[0] == 0.0 and np.array_equal(tr.q[0], [0.5, 0.2])


def test_report_warnings_are_python_warnings_of_our_category(arm):
    # rk4 at a step far too coarse for the chaotic 2R arm: the report warns that the estimate is of order one
    with pytest.warns(dynamics.SimulationWarning) as caught:
        tr = dynamics.simulate(arm, [np.pi / 2, np.pi / 4], [0, 0], 3.0, integrator="rk4", dt=0.15)
    assert tr.report["warnings"] and [str(w.message) for w in caught] == tr.report["warnings"]
    assert issubclass(dynamics.SimulationWarning, UserWarning)
    with warnings.catch_warnings():  # a filter on the category turns them into errors
        warnings.simplefilter("error", dynamics.SimulationWarning)
        with pytest.raises(dynamics.SimulationWarning, match="of order one"):
            dynamics.simulate(arm, [np.pi / 2, np.pi / 4], [0, 0], 3.0, integrator="rk4", dt=0.15)


def test_processes_without_main_guard_say_so(tmp_path):
    script = tmp_path / "unguarded.py"
    script.write_text(
        "import dynamics\n"
        f"arm = dynamics.load_urdf({os.path.join(OUR_ROBOTS, 'planar_2r.urdf')!r})\n"
        "dynamics.simulate_many(arm, [[0.1, 0.2], [0.2, 0.1]], [0.0, 0.0], 0.01, engine='processes')\n")
    env = dict(os.environ, PYTHONPATH=REPO + os.pathsep + os.environ.get("PYTHONPATH", ""))
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode != 0
    assert "__main__" in out.stderr and "InputError" in out.stderr and "BrokenProcessPool" not in out.stderr
    assert out.stderr.count("Traceback") == 1  # the script did not run again in worker processes


def test_compiled_loop_releases_the_gil(arm):
    kw = dict(integrator="rk4", dt=1e-4, error_estimate="none", sample_dt=0.1, progress=False)
    dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 0.01, **kw)  # compiled before the measured run
    result = {}
    runner = threading.Thread(target=lambda: result.update(r=dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0],
                                                                               60.0, **kw)))
    beats = []
    runner.start()
    while runner.is_alive():  # this thread's Python keeps running while the other is in compiled code
        beats.append(time.perf_counter())
        time.sleep(0.001)
    runner.join()
    wall = result["r"].report["wall_time_s"]
    gaps = np.diff(beats)
    assert wall > 0.2 and len(beats) > 20
    assert gaps.max() < 0.5 * wall  # holding the GIL, the compiled run would be one gap as long as itself


