"""What one right-hand side of a simulation costs in the C++ core, with and without contact (issue 19's robot
touching nothing).

    python -m benchmarks.problem_calls [--steps N] [--calls N] [--repeat R]

Go1 (example-robot-data) under PD, four foot spheres, the ground 10 m below (the broad phase finds nothing to
touch), the two problems alternated, the best of R per call:

* **rhs (rk4)**: no binding evaluates the right-hand side alone, so a ``simulate`` with rk4 over N steps
  (dt = 0.1 ms, ``error_estimate="none"``, two samples) is timed by its own ``report["wall_time_s"]`` and divided
  by its ``rhs_evals`` (4 per step): the right-hand side with rk4's few vector operations around it;
* **f and J (one call)**: ``_core.problem_jacobian`` from Python, which builds the core's robot problem, evaluates
  f and the analytical Jacobian df/dz (Radau's Newton matrix): one call's wall time, the binding's overhead
  included.

The numba problem's separate ``rebase`` has no counterpart to time (the core's chart update is inside its steps).
Printed as a markdown table and written to benchmarks/out/problem_calls.md.
"""

import argparse
import importlib
import time
import warnings
from pathlib import Path

import numpy as np

from .contact_idle import FEET, go1

OUT = Path(__file__).resolve().parent / "out" / "problem_calls.md"
DT = 1e-4


def cases():
    """{"none": contact, "contact": contact}: the Go1 model, q0, its PD and the two contacts."""
    import dynamics
    model, q0, pd = go1()
    contact = dynamics.Contact(ground=dynamics.Ground(height=-10.0),
                               geometries=[dynamics.Sphere(f, 0.02) for f in FEET])
    return model, q0, pd, {"none": None, "contact": contact}


def rhs_per_call(model, q0, pd, contact, steps):
    """Seconds per right-hand side of an rk4 run of ``steps`` steps (its own wall time over its rhs_evals)."""
    import dynamics
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = dynamics.simulate(model, q0, np.zeros(model.nv), steps * DT, torque=pd, contact=contact,
                               integrator="rk4", dt=DT, sample_dt=steps * DT, error_estimate="none", progress=False)
    return tr.report["wall_time_s"] / tr.report["rhs_evals"]


def jacobian_call(model, q0, pd, contact):
    """A function calling ``_core.problem_jacobian`` once on simulate's passive torques, source and contact."""
    from dynamics import _core
    from dynamics.contact.resolve import core_contact, resolve
    from dynamics.control.validation import make_source
    from dynamics.simulation.native import core_passive, core_source
    sm = importlib.import_module("dynamics.simulation.simulate")  # (the package's attribute is the function)
    s = sm._settings(model, q0, np.zeros(model.nv), 1.0, "radau", 1e-6, 1e-8, None, None, None, 10, "none", ("q",),
                     [], None, False)
    passive = core_passive(model, sm._passive(model, s, None, 1e4, 100.0, 1e-3))
    source = core_source(model, make_source(model, pd))
    cc = None if contact is None else core_contact(resolve(contact, model), model)  # (kept alive by the closure)
    cm = None if cc is None else cc.core
    n = 2 * model.nv + (3 if cm is not None else 2)
    z, f, J = np.zeros(n), np.zeros(n), np.zeros((n, n))
    q = s.q0
    z[model.nv:2 * model.nv] = 0.1  # moving

    def call():
        return _core.problem_jacobian(model.core, passive, source, q, z, 0.0, f, J, None if cc is None else cm)
    return call


def best_per_call(fn, calls):
    t = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - t) / calls


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=10_000, help="rk4 steps per run")
    ap.add_argument("--calls", type=int, default=2_000, help="problem_jacobian calls per round")
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args(argv)
    model, q0, pd, contacts = cases()
    jac = {name: jacobian_call(model, q0, pd, c) for name, c in contacts.items()}
    for name, c in contacts.items():  # warm-up
        rhs_per_call(model, q0, pd, c, 10)
        jac[name]()
    best = {}
    for _ in range(args.repeat):
        for name, c in contacts.items():
            t = rhs_per_call(model, q0, pd, c, args.steps)
            best["rhs", name] = min(best.get(("rhs", name), np.inf), t)
            t = best_per_call(jac[name], args.calls)
            best["jac", name] = min(best.get(("jac", name), np.inf), t)
    lines = [f"Go1 (nv {model.nv}) under PD, four foot spheres 10 m above the ground; best of {args.repeat}, the two "
             "problems alternated.", "",
             "| function | without contact (us) | with contact (us) | ratio |", "|---|---:|---:|---:|"]
    for key, label in (("rhs", f"rhs (rk4 run of {args.steps} steps / rhs_evals)"),
                       ("jac", "f and J (`_core.problem_jacobian`, one call from Python)")):
        a, b = best[key, "none"], best[key, "contact"]
        lines.append(f"| {label} | {a * 1e6:.2f} | {b * 1e6:.2f} | {b / a:.3f} |")
    text = "\n".join(lines)
    print(text)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(text + "\n")


if __name__ == "__main__":
    main()
