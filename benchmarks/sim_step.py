"""Cost of one right-hand-side evaluation inside the simulation loop, two source trees alternately in one run.

    python -m benchmarks.sim_step [--before DIR] [--rounds N]

For each integrator (rk4 at dt = 1e-3, the default ``auto``), 20 s of the 2R arm under gravity: the
integration run's wall time (``report["wall_time_s"]``) divided by its right-hand-side evaluations (solver work
included), best of 5 runs, in a fresh interpreter per tree and round (one numba cache per tree), the trees alternating
(``--before``: a checkout of the library to compare with, e.g. ``git archive <commit> dynamics robots | tar -x
-C DIR``).  Alternating rounds make the comparison fair on a shared, noisy machine.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

SCRIPT = r"""
import json, sys
import dynamics
arm = dynamics.load_urdf(sys.argv[1])
out = {}
for name, kw in (("rk4", dict(integrator="rk4", dt=1e-3, sample_dt=0.1)), ("auto", dict(sample_dt=0.1))):
    dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 0.1, **kw)  # compiled or loaded from the cache
    best = min((lambda r: r["wall_time_s"] / r["rhs_evals"])(dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 20.0,
                                                                              **kw).report) for _ in range(5))
    out[name] = best * 1e6
print(json.dumps(out))
"""

ROOT = Path(__file__).resolve().parent.parent


def per_step(tree, cache):
    env = dict(os.environ, PYTHONPATH=str(tree), PYTHONDONTWRITEBYTECODE="1", NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", SCRIPT, str(ROOT / "robots" / "planar_2r.urdf")], env=env,
                         capture_output=True, text=True, check=True, cwd="/")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", required=True, help="directory holding the library to compare with")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args(argv)
    rows = {"before": [], "after": []}
    with tempfile.TemporaryDirectory() as d:  # one numba cache per tree, warm after the first round
        for _ in range(args.rounds):
            rows["before"].append(per_step(Path(args.before), Path(d, "before")))
            rows["after"].append(per_step(ROOT, Path(d, "after")))
    print("| tree | rk4: us per rhs evaluation (each round) | auto: us per rhs evaluation (each round) |")
    print("|---|---|---|")
    for tree, rs in rows.items():
        rk4, auto = (", ".join(f"{r[k]:.2f}" for r in rs) for k in ("rk4", "auto"))
        print(f"| {tree} | {rk4} | {auto} |")
    for key in ("rk4", "auto"):
        b = min(r[key] for r in rows["before"])
        a = min(r[key] for r in rows["after"])
        print(f"{key}: best before {b:.2f} us, after {a:.2f} us, ratio {a / b:.3f}")


if __name__ == "__main__":
    main()
