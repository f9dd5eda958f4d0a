"""numba's ``inline="always"`` copies the callee's scope once per block: measurements for the upstream patch.

    python -m benchmarks.numba_inliner repro [--patched]          # plain numba, none of our code
    python -m benchmarks.numba_inliner cold [--runs N]            # our kernels, three inliners, alternately
    python -m benchmarks.numba_inliner check-patch                # the patch applies to the installed numba

The write-up is docs/upstream/numba-inline-scope-copy.md, the patch docs/upstream/numba-inline-scope-copy.patch
(against numba's ``numba/core/inline_closurecall.py``).

``repro`` compiles, in plain numba, a caller of one ``@njit(inline="always")`` callee generated with B branches
(blocks) and V local variables, for a grid of (B, V), and counts the ``ir.Var`` copies made while inlining and
the CPU time spent in ``InlineWorker.inline_ir``: numba's per-block ``copy.deepcopy`` copies the whole scope
(every variable) for each block, so copies grow as B x V.  ``--patched`` runs the same in a fresh interpreter
whose ``numba`` is a temporary copy of the installed one with the patch applied.  The counters are wrappers set
in that measuring process only.

``cold`` times, each in a fresh interpreter with an empty ``NUMBA_CACHE_DIR``, a first rk4 ``simulate`` of the
2R arm (robots/planar_2r.urdf, 1 s at dt = 1e-3) and a first ``inverse_dynamics`` (import and load_urdf
excluded), with three inliners, run alternately:

* ``library``: ``import dynamics`` as it is (a library that installs its own fix of the inliner uses it);
* ``numba``: numba's own inliner (if ``import dynamics`` replaced ``ir.Scope.__deepcopy__`` or
  ``InlineWorker.inline_ir``, the originals are put back before the first compile);
* ``patched``: as ``numba``, with the temporary copy of numba carrying the upstream patch.

It prints the median and the spread (min-max) of the workload's CPU seconds (the machine is shared: CPU time
is the steadier figure) and wall seconds, and checks that every inliner gives the same numbers bit for bit.
"""

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PATCH = ROOT / "docs" / "upstream" / "numba-inline-scope-copy.patch"
URDF = ROOT / "robots" / "planar_2r.urdf"

# ---------------------------------------------------------------------------------------------------------------
# The reproduction: plain numba, a generated callee of B blocks and V variables

REPRO = r"""
import json, sys, time
import numba
import numpy as np
from numba.core import ir
from numba.core.inline_closurecall import InlineWorker

counts = {"var_copies": 0, "inline_s": 0.0, "inlines": 0, "ir_blocks": 0, "scope_vars": 0}
var_deepcopy = ir.Var.__deepcopy__
inline_ir = InlineWorker.inline_ir

def counting_var_deepcopy(self, memo):
    counts["var_copies"] += 1
    return var_deepcopy(self, memo)

def timed_inline_ir(self, caller_ir, block, i, callee_ir, *args, **kwargs):
    # the callee's IR as the inliner gets it: its blocks, and the variables of its scope (after SSA: each
    # assignment in a branch is a new version, so the scope grows with the blocks too)
    counts["ir_blocks"] = max(counts["ir_blocks"], len(callee_ir.blocks))
    scope = next(iter(callee_ir.blocks.values())).scope
    counts["scope_vars"] = max(counts["scope_vars"], len(scope.localvars))
    args = (caller_ir, block, i, callee_ir, *args)
    t0 = time.process_time()
    try:
        return inline_ir(self, *args, **kwargs)
    finally:
        counts["inline_s"] += time.process_time() - t0
        counts["inlines"] += 1

ir.Var.__deepcopy__ = counting_var_deepcopy
InlineWorker.inline_ir = timed_inline_ir

def make(blocks, nvars):
    # V variables live through the whole function; each of the B branches reads and writes one of them
    lines = ["def callee(x):"]
    lines += [f"    v{k} = x[{k % 4}] * {k + 1}.0" for k in range(nvars)]
    lines += ["    s = 0.0"]
    for b in range(blocks):
        k = b % nvars
        lines += [f"    if x[{b % 4}] > {b / blocks:.3f}:", f"        v{k} = v{k} + s", f"        s = s + v{k}"]
    lines += ["    return s + " + " + ".join(f"v{k}" for k in range(nvars))]
    ns = {}
    exec("\n".join(lines), ns)
    callee = numba.njit(inline="always")(ns["callee"])
    ns2 = {"callee": callee}
    exec("def caller(x):\n    return callee(x)", ns2)
    return ns["callee"], numba.njit(ns2["caller"])

x = np.linspace(0.1, 0.9, 4)
rows = []
for blocks, nvars in json.loads(sys.argv[1]):
    py, caller = make(blocks, nvars)
    for k in counts:
        counts[k] = type(counts[k])(0)
    t0 = time.process_time()
    got = caller(x)
    total = time.process_time() - t0
    assert got == py(x), (got, py(x))  # the same operations in the same order: equal
    rows.append(dict(blocks=blocks, nvars=nvars, compile_s=total, **counts))
print(json.dumps({"numba": numba.__version__, "numba_file": numba.__file__, "rows": rows}))
"""

GRID = [(8, 8), (16, 8), (32, 8), (64, 8), (128, 8), (32, 16), (32, 32), (32, 64), (128, 64)]


def patched_numba(dest: str) -> str:
    """A copy of the installed numba package under ``dest`` with the patch applied; returns the directory to put
    first on PYTHONPATH."""
    import numba  # only to find it; the measuring interpreters import their own
    src = Path(numba.__file__).resolve().parent
    shutil.copytree(src, Path(dest) / "numba", ignore=shutil.ignore_patterns("__pycache__"))
    out = subprocess.run(["patch", "-p1", "--forward", "-d", dest, "-i", str(PATCH)], capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"the patch does not apply to numba {numba.__version__}:\n{out.stdout}{out.stderr}")
    return dest


def _run(code, args, env=None):
    out = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=env, cwd=ROOT)
    if out.returncode:
        sys.stderr.write(out.stderr)
        raise SystemExit(f"measuring process failed (exit {out.returncode})")
    return json.loads(out.stdout.strip().splitlines()[-1])


def repro(patched: bool):
    with tempfile.TemporaryDirectory(prefix="numba-patched-") as d:
        env = dict(os.environ)
        if patched:
            env["PYTHONPATH"] = os.pathsep.join(filter(None, [patched_numba(d), env.get("PYTHONPATH")]))
        r = _run(REPRO, [json.dumps(GRID)], env)
    print(f"numba {r['numba']} ({'with the patch' if patched else 'as installed'}): one caller, one inlined callee "
          f"of B blocks and V variables")
    print("| branches | source variables | IR blocks | scope variables | inlinings | Var copies | "
          "copies / (blocks x scope variables x inlinings) | CPU s in inline_ir | CPU s compile |\n"
          "|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for row in r["rows"]:
        per = row["var_copies"] / (row["ir_blocks"] * row["scope_vars"] * max(row["inlines"], 1))
        print(f"| {row['blocks']} | {row['nvars']} | {row['ir_blocks']} | {row['scope_vars']} | {row['inlines']} | "
              f"{row['var_copies']} | {per:.2f} | {row['inline_s']:.3f} | {row['compile_s']:.2f} |")
    return r


# ---------------------------------------------------------------------------------------------------------------
# Cold compiles of our kernels with each inliner

COLD = r"""
import hashlib, json, sys, time
import numpy as np
import dynamics
from numba.core import ir
from numba.core.inline_closurecall import InlineWorker
import numba

mode, workload, urdf = sys.argv[1:4]
if mode != "library":
    # numba's own inliner: undo what importing the library may have replaced (nothing is compiled before this)
    nb = sys.modules.get("dynamics._numba")
    if "__deepcopy__" in vars(ir.Scope):
        del ir.Scope.__deepcopy__
    original = getattr(nb, "_numba_inline_ir", None)
    if original is not None:
        InlineWorker.inline_ir = original
inliner = InlineWorker.inline_ir
own = inliner.__module__ == "numba.core.inline_closurecall" and "__deepcopy__" not in vars(ir.Scope)
import inspect
upstream = "scope_copies" in inspect.getsource(inliner) if own else False

arm = dynamics.load_urdf(urdf)
w0, c0 = time.perf_counter(), time.process_time()
if workload == "rk4":
    out = dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 1.0, integrator="rk4", dt=1e-3)
    values = np.asarray(out.q)
else:
    values = dynamics.inverse_dynamics(arm, np.array([0.5, 0.2]), np.array([0.1, -0.3]), np.array([1.0, 2.0]))
cpu, wall = time.process_time() - c0, time.perf_counter() - w0
print(json.dumps({"cpu": cpu, "wall": wall, "numba_inliner": own, "upstream_patch": upstream,
                  "numba": numba.__version__, "digest": hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest()}))
"""

MODES = ("library", "numba", "patched")
WORKLOADS = (("rk4", "first rk4 simulate, 2R arm"), ("id", "first inverse_dynamics, 2R arm"))


def cold(runs: int, modes=MODES, workloads=("rk4", "id")):
    results = {(m, w): [] for m in modes for w in workloads}
    with tempfile.TemporaryDirectory(prefix="numba-patched-") as d:
        patched_path = patched_numba(d) if "patched" in modes else None
        for k in range(runs):
            for w in workloads:
                order = modes[k % len(modes):] + modes[:k % len(modes)]  # rotate: no mode always runs first
                for m in order:
                    with tempfile.TemporaryDirectory(prefix="numba-cold-") as cache:
                        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
                        if m == "patched":
                            env["PYTHONPATH"] = os.pathsep.join(filter(None, [patched_path, env.get("PYTHONPATH")]))
                        r = _run(COLD, [m, w, str(URDF)], env)
                    results[m, w].append(r)
                    print(f"run {k + 1}/{runs} {w:>3} {m:>8}: CPU {r['cpu']:6.2f} s, wall {r['wall']:6.2f} s, "
                          f"numba's inliner {r['numba_inliner']}, upstream patch {r['upstream_patch']}", flush=True)
    print(f"\nnumba {next(iter(results.values()))[0]['numba']}, {runs} runs each, alternately; median (min-max)")
    print("| workload | inliner | CPU s | wall s |\n|---|---|---:|---:|")
    label = dict(WORKLOADS)
    for w in workloads:
        digests = {r["digest"] for m in modes for r in results[m, w]}
        for m in modes:
            cpu = [r["cpu"] for r in results[m, w]]
            wall = [r["wall"] for r in results[m, w]]
            print(f"| {label[w]} | {m} | {statistics.median(cpu):.2f} ({min(cpu):.2f}-{max(cpu):.2f}) | "
                  f"{statistics.median(wall):.2f} ({min(wall):.2f}-{max(wall):.2f}) |")
        print(f"| {label[w]}: results of all runs bit-identical | {'yes' if len(digests) == 1 else 'NO'} | | |")
    return results


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("repro", help="the quadratic copy in plain numba")
    p.add_argument("--patched", action="store_true", help="with the patch applied to a copy of numba")
    p = sub.add_parser("cold", help="cold compiles of our kernels with each inliner")
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES))
    p.add_argument("--workloads", nargs="+", choices=[w for w, _ in WORKLOADS], default=[w for w, _ in WORKLOADS])
    sub.add_parser("check-patch", help="apply the patch to a copy of the installed numba")
    args = ap.parse_args(argv)
    if args.cmd == "repro":
        repro(args.patched)
    elif args.cmd == "cold":
        cold(args.runs, tuple(args.modes), tuple(args.workloads))
    else:
        with tempfile.TemporaryDirectory(prefix="numba-patched-") as d:
            patched_numba(d)
        print(f"{PATCH.name} applies to the installed numba")


if __name__ == "__main__":
    main()
