"""What one call of a simulation's problem functions costs, with and without contact (issue 19's robot touching
nothing).

    python -m benchmarks.problem_calls [--calls N] [--repeat R]

Go1 (example-robot-data) under PD, four foot spheres, the ground 10 m below (the contact code skipped:
:mod:`dynamics.contact.clearance`).  The problem a simulation's compiled loop gets is taken from a short run of
``simulate`` (its call of :func:`dynamics.simulation.run.run`, intercepted), then each of ``rhs`` and ``rebase``
is called N times in a compiled loop of its own, the two problems alternated; the best of R per call.  One
function per loop: a loop that calls both compiles differently (it once showed a rebase at 0.65 us that costs
0.2-0.3 us alone).
"""

import argparse
import importlib
import time
import warnings

import numba
import numpy as np

from dynamics._numba import borrow
from dynamics.simulation.solvers.interface import problem_rebase, problem_rhs

from .contact_idle import FEET, go1


@numba.njit(nogil=True)
def _rhs_loop(p, z, n):
    b = borrow(p)
    dz = np.zeros_like(z)
    for _ in range(n):
        z[0] += 1e-9
        problem_rhs(b, 0.0, z, dz)
    return dz[-1]


@numba.njit(nogil=True)
def _rebase_loop(p, z, n):
    b = borrow(p)
    dz = np.zeros_like(z)
    mag = np.ones(z.shape[0])
    for _ in range(n):
        z[0] += 1e-9
        problem_rebase(b, 0.0, z, dz, mag)
    return mag[0]


def problems():
    """{"none": (p, z), "contact": (p, z)}: Go1's problem and initial state as simulate builds them."""
    import dynamics
    sm = importlib.import_module("dynamics.simulation.simulate")  # the module (the package's attribute of that
    # name is the function)
    model, q0, pd = go1()
    contact = dynamics.Contact(ground=dynamics.Ground(height=-10.0),
                               geometries=[dynamics.Sphere(f, 0.02) for f in FEET])
    got, real = {}, sm.run

    def spy(method, p, z, t_end, opt, t0=0.0, watch=None):
        got["p"], got["z"] = p, z.copy()
        return real(method, p, z, t_end, opt, t0=t0, watch=watch)
    out = {}
    sm.run = spy
    try:
        for name, c in (("none", None), ("contact", contact)):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                dynamics.simulate(model, q0, np.zeros(model.nv), 0.001, torque=pd, contact=c, integrator="rk4",
                                  dt=1e-3, error_estimate="none")
            out[name] = (got["p"], got["z"])
    finally:
        sm.run = real
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=100_000)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    P = problems()
    loops = {"rhs": _rhs_loop, "rebase": _rebase_loop}
    for f in loops.values():
        for p, z in P.values():
            f(p, z.copy(), 10)  # compile
    best = {}
    for _ in range(args.repeat):
        for fname, f in loops.items():
            for pname, (p, z) in P.items():
                zz = z.copy()
                t = time.perf_counter()
                f(p, zz, args.calls)
                dt = (time.perf_counter() - t) / args.calls
                best[fname, pname] = min(best.get((fname, pname), np.inf), dt)
    print("| function | without contact (us) | with contact (us) | ratio |")
    print("|---|---:|---:|---:|")
    for fname in loops:
        a, b = best[fname, "none"], best[fname, "contact"]
        print(f"| {fname} | {a * 1e6:.2f} | {b * 1e6:.2f} | {b / a:.3f} |")


if __name__ == "__main__":
    main()
