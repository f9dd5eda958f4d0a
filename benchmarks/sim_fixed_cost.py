"""The fixed cost of ``simulate`` (issue 24), two source trees alternately in one run.

    python -m benchmarks.sim_fixed_cost [--before DIR] [--rounds N] [--cold]

Per tree and round, in a fresh interpreter (one warm numba cache per tree), Panda (example-robot-data,
``mimic="independent"``) under PD towards a posture:

* ``fixed_ms``: a 1 ms simulation (``error_estimate="none"``), the whole call's wall time less the compiled
  run's (``report["wall_time_s"]``), median of 30 calls: what every run of a sweep pays besides its steps;
* ``overhead_1s``: a 1 s simulation (default error estimate): the share of the call's wall time spent
  neither in the run nor in its error estimate, median of 7;
* ``cost_of_estimate``: the error estimate's wall time over the run's (same 1 s simulation);
* ``us_per_rhs``: the run's wall time per right-hand-side evaluation (solver work included).

``--cold``: also, per tree, the CPU seconds of a fresh interpreter with an empty numba cache running the
first simulate of the 2R arm with rk4 and with the default ``auto`` (benchmarks.core's cold-start script).
``--before``: a checkout of the library to compare with (``git archive <commit> dynamics robots | tar -x -C
DIR``); without it, only this tree.  Alternating rounds make the comparison fair on a shared, noisy machine:
read the ratios, not the absolute times.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

SCRIPT = r"""
import json, statistics, time
import numpy as np
import dynamics
from dynamics.torques import PD
model = dynamics.load_urdf(dynamics.robots.example_robot_data("panda_description/urdf/panda.urdf"),
                           mimic="independent")
rng = np.random.default_rng(0)
target = model.neutral() + rng.uniform(-0.3, 0.3, model.nq)
pd = PD(target, 200.0, 20.0, tau_ff=dynamics.gravity_torques(model, target))
q0, v0 = model.neutral() + 0.1, np.zeros(model.nv)

def call(duration, **kw):
    t0 = time.perf_counter()
    tr = dynamics.simulate(model, q0, v0, duration, torque=pd, **kw)
    return time.perf_counter() - t0, tr.report

call(1.0)  # compiled or loaded from the cache
call(0.001, error_estimate="none")
fixed = statistics.median(w - r["wall_time_s"] for w, r in (call(0.001, error_estimate="none") for _ in range(30)))
runs = [call(1.0) for _ in range(7)]
over = statistics.median((w - r["wall_time_s"] - r["error_estimate_wall_time_s"]) / w for w, r in runs)
est = statistics.median(r["error_estimate_wall_time_s"] / r["wall_time_s"] for w, r in runs)
rhs = min(r["wall_time_s"] / r["rhs_evals"] for w, r in runs)
print(json.dumps({"fixed_ms": fixed * 1e3, "overhead_1s": over, "cost_of_estimate": est, "us_per_rhs": rhs * 1e6}))
"""

ROOT = Path(__file__).resolve().parent.parent
KEYS = ("fixed_ms", "overhead_1s", "cost_of_estimate", "us_per_rhs")


def _run(tree, cache, code, *args):
    env = dict(os.environ, PYTHONPATH=str(tree), PYTHONDONTWRITEBYTECODE="1", NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True, text=True,
                         check=True, cwd="/")
    return json.loads(out.stdout.strip().splitlines()[-1])


def cold(tree):
    """CPU seconds of a fresh interpreter's first rk4 and first auto simulate (2R arm), empty cache each."""
    from benchmarks.core import SIM_COLD_SCRIPT
    arm = str(ROOT / "robots" / "planar_2r.urdf")
    out = {}
    for case in ("rk4", "default"):
        with tempfile.TemporaryDirectory(prefix="numba-cold-") as d:
            out[case] = _run(tree, d, SIM_COLD_SCRIPT, arm, case)["cpu"]
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", help="directory holding the library to compare with")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cold", action="store_true", help="also the cold start (empty numba cache), CPU s")
    args = ap.parse_args(argv)
    trees = {"before": Path(args.before)} if args.before else {}
    trees["after"] = ROOT
    rows = {name: [] for name in trees}
    colds = {name: [] for name in trees}
    with tempfile.TemporaryDirectory() as d:  # one numba cache per tree, warm after the first round
        for _ in range(args.rounds):
            for name, tree in trees.items():
                rows[name].append(_run(tree, Path(d, name), SCRIPT))
                if args.cold:
                    colds[name].append(cold(tree))
    print("| tree | " + " | ".join(KEYS) + (" | cold rk4 CPU s | cold auto CPU s |" if args.cold else " |"))
    print("|---|" + "---|" * (len(KEYS) + 2 * args.cold))
    for name, rs in rows.items():
        cells = [", ".join(f"{r[k]:.3g}" for r in rs) for k in KEYS]
        if args.cold:
            cells += [", ".join(f"{c[k]:.1f}" for c in colds[name]) for k in ("rk4", "default")]
        print(f"| {name} | " + " | ".join(cells) + " |")
    if args.before:
        for k in KEYS:
            b = min(r[k] for r in rows["before"])
            a = min(r[k] for r in rows["after"])
            print(f"{k}: after / before = {a / b:.3g} (best of each)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
