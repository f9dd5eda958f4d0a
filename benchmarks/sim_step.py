"""Cost of one right-hand-side evaluation inside the simulation loop.

    python -m benchmarks.sim_step [--before PYTHON] [--rounds N]

For each integrator (rk4 at dt = 1e-3, the default ``auto``), 20 s of the 2R arm under gravity: the
integration run's wall time (``report["wall_time_s"]``) divided by its right-hand-side evaluations (solver work
included), best of 5 runs (after a first call), in a fresh interpreter per round.  ``--before``: the Python
interpreter of another checkout (``other/.venv/bin/python``, the ``dynamics`` it has installed), run alternately
with this one: alternating rounds make the comparison fair on a shared, noisy machine.  Printed as a markdown table
and written to benchmarks/out/sim_step.md.
"""

import argparse
import json
import subprocess
import sys
from pathlib import Path

SCRIPT = r"""
import json, sys
import dynamics
arm = dynamics.load_urdf(sys.argv[1])
out = {}
for name, kw in (("rk4", dict(integrator="rk4", dt=1e-3, sample_dt=0.1)), ("auto", dict(sample_dt=0.1))):
    dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 0.1, **kw)  # first call
    best = min((lambda r: r["wall_time_s"] / r["rhs_evals"])(dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 20.0,
                                                                              **kw).report) for _ in range(5))
    out[name] = best * 1e6
print(json.dumps(out))
"""

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "out" / "sim_step.md"


def per_step(python):
    """SCRIPT in a fresh interpreter ``python``, run from / so that the ``dynamics`` it has installed is imported."""
    out = subprocess.run([python, "-c", SCRIPT, str(ROOT / "robots" / "planar_2r.urdf")], capture_output=True,
                         text=True, check=True, cwd="/")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", help="the Python interpreter of another checkout to compare with")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    pythons = {"before": args.before} if args.before else {}
    pythons["after"] = sys.executable
    rows = {name: [] for name in pythons}
    for _ in range(args.rounds):
        for name, python in pythons.items():
            rows[name].append(per_step(python))
    lines = ["| tree | rk4: us per rhs evaluation (each round) | auto: us per rhs evaluation (each round) |",
             "|---|---|---|"]
    for tree, rs in rows.items():
        rk4, auto = (", ".join(f"{r[k]:.2f}" for r in rs) for k in ("rk4", "auto"))
        lines.append(f"| {tree} | {rk4} | {auto} |")
    if args.before:
        lines.append("")
        for key in ("rk4", "auto"):
            b = min(r[key] for r in rows["before"])
            a = min(r[key] for r in rows["after"])
            lines.append(f"{key}: best before {b:.2f} us, after {a:.2f} us, ratio {a / b:.3f}")
    text = "\n".join(lines)
    print(text)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(text + "\n")


if __name__ == "__main__":
    main()
