"""The fixed cost of ``simulate`` (issue 24): what every call pays besides its steps.

    python -m benchmarks.sim_fixed_cost [--before PYTHON] [--rounds N] [--calls N]

Per round, in a fresh interpreter (the first calls of each kind made before timing), Panda (example-robot-data,
``mimic="independent"``) under PD towards a posture:

* ``rk4 step``: one rk4 step, duration = dt = 0.1 ms, ``error_estimate="none"``: the whole call's wall time
  (``call_ms``), the part outside the core's run (``fixed_ms`` = the call less ``report["wall_time_s"]``) and the
  run (``run_ms``: the binding's call, the stability probe at t0 and the step), median of --calls calls;
* ``auto 1 ms``: the default call (``auto``, default error estimate, 1,001 samples) on a 1 ms simulation: the
  whole call (``call_ms``), its part neither in the run nor in its error estimate (``fixed_ms``) and those two
  runs (``run_ms``), median of --calls calls;
* ``overhead_1s``: a 1 s simulation (default error estimate): the share of the call's wall time spent neither in
  the run nor in its error estimate, median of 7; ``cost_of_estimate``: the error estimate's wall time over the
  run's; ``us_per_rhs``: the run's wall time per right-hand-side evaluation (solver work included).

``--before``: the Python interpreter of another checkout (``other/.venv/bin/python``, the ``dynamics`` it has
installed); the two run alternately, a fresh interpreter each round, which makes the comparison fair on a shared,
noisy machine: read the ratios, not the absolute times.  Printed as a markdown table and written to
benchmarks/out/sim_fixed_cost.md.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

SCRIPT = r"""
import json, statistics, sys, time
import numpy as np
import dynamics
from dynamics.torques import PD
calls = int(sys.argv[1])
model = dynamics.load_urdf(dynamics.robots.example_robot_data("panda_description/urdf/panda.urdf"),
                           mimic="independent")
rng = np.random.default_rng(0)
target = model.neutral() + rng.uniform(-0.3, 0.3, model.nq)
pd = PD(target, 200.0, 20.0, tau_ff=dynamics.gravity_torques(model, target))
q0, v0 = model.neutral() + 0.1, np.zeros(model.nv)

def call(duration, **kw):
    t0 = time.perf_counter()
    tr = dynamics.simulate(model, q0, v0, duration, torque=pd, progress=False, **kw)
    return time.perf_counter() - t0, tr.report

RK4 = dict(integrator="rk4", dt=1e-4, error_estimate="none")
call(1e-4, **RK4)  # first calls
call(1e-3)
call(1.0)
rk4 = [call(1e-4, **RK4) for _ in range(calls)]
auto = [call(1e-3) for _ in range(calls)]
runs = [call(1.0) for _ in range(7)]
med = statistics.median
rest = lambda w, r: w - r["wall_time_s"] - r.get("error_estimate_wall_time_s", 0.0)
print(json.dumps({
    "rk4_call_ms": med(w for w, r in rk4) * 1e3, "rk4_fixed_ms": med(rest(w, r) for w, r in rk4) * 1e3,
    "rk4_run_ms": med(r["wall_time_s"] for w, r in rk4) * 1e3,
    "auto_call_ms": med(w for w, r in auto) * 1e3, "auto_fixed_ms": med(rest(w, r) for w, r in auto) * 1e3,
    "auto_run_ms": med(w - rest(w, r) for w, r in auto) * 1e3,
    "overhead_1s": med(rest(w, r) / w for w, r in runs),
    "cost_of_estimate": med(r["error_estimate_wall_time_s"] / r["wall_time_s"] for w, r in runs),
    "us_per_rhs": min(r["wall_time_s"] / r["rhs_evals"] for w, r in runs) * 1e6}))
"""

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "out" / "sim_fixed_cost.md"
KEYS = ("rk4_call_ms", "rk4_fixed_ms", "rk4_run_ms", "auto_call_ms", "auto_fixed_ms", "auto_run_ms", "overhead_1s",
        "cost_of_estimate", "us_per_rhs")


def _run(python, calls):
    """SCRIPT in a fresh interpreter ``python`` (this checkout's: sys.executable), run from / so that the
    ``dynamics`` it has installed is the one imported."""
    out = subprocess.run([python, "-c", SCRIPT, str(calls)], capture_output=True, text=True, check=True, cwd="/")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", help="the Python interpreter of another checkout to compare with")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--calls", type=int, default=30, help="calls per median (rk4 step, auto 1 ms)")
    args = ap.parse_args(argv)
    pythons = {"before": args.before} if args.before else {}
    pythons["after"] = sys.executable
    rows = {name: [] for name in pythons}
    for _ in range(args.rounds):
        for name, python in pythons.items():
            rows[name].append(_run(python, args.calls))
    lines = ["Panda under PD; `rk4 step`: duration = dt = 0.1 ms, error_estimate='none'; `auto 1 ms`: the default "
             f"call, 1,001 samples; medians of {args.calls} calls, each round a fresh interpreter.", "",
             "| tree | " + " | ".join(KEYS) + " |", "|---|" + "---:|" * len(KEYS)]
    for name, rs in rows.items():
        lines.append(f"| {name} | " + " | ".join(", ".join(f"{r[k]:.3g}" for r in rs) for k in KEYS) + " |")
    if args.before:
        lines.append("")
        for k in KEYS:
            b = min(r[k] for r in rows["before"])
            a = min(r[k] for r in rows["after"])
            lines.append(f"{k}: after / before = {a / b:.3g} (best of each)")
    text = "\n".join(lines)
    print(text)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
