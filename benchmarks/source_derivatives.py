"""Analytical torque-source derivatives against the central differences they replaced in Radau's Newton matrix:
`python -m benchmarks.source_derivatives`.

For a PD and a computed-torque source on Panda and on the stiff 10-link chain (damping 1e3, benchmarks
.work_precision's), and the operational-space controller (a pose target with a posture task) on Panda, in one
process, alternately (best of --repeat):

* one Jacobian of the robot's right-hand side (:func:`dynamics.simulation.jacobian.robot_jacobian`);
* a whole Radau run (rtol 1e-8).

"Differenced" is the previous code path itself: the source's kind tag is swapped for a benchmark-only tag
whose evaluation is the same kind's but which has no analytical derivative, so ``source_derivatives`` falls
back to its central differences (``_source_differences``).  Ratios are differenced / analytical (above 1.0 the
analytical is faster).  Also prints the largest difference of the two runs' final states.
"""

from __future__ import annotations

import argparse
import time
from typing import NamedTuple

import numpy as np

import dynamics
from benchmarks.work_precision import chain_urdf, erd
from dynamics.control import derivatives, dispatch
from dynamics.simulation import problem as problem_module
from dynamics.simulation.jacobian import robot_jacobian
from dynamics.simulation.problem import robot_problem
from dynamics.simulation.solvers.interface import new_stats
from dynamics.torque_derivatives import _passive
from dynamics.torques import PD, ComputedTorque, Target, make_source


class DifferencedPD(NamedTuple):
    """A PD source with no analytical derivative (benchmark only)."""


class DifferencedComputedTorque(NamedTuple):
    """A computed-torque source with no analytical derivative (benchmark only)."""


class DifferencedOperationalSpace(NamedTuple):
    """An operational-space source with no analytical derivative (benchmark only)."""


dispatch._EVAL[DifferencedPD] = dispatch._EVAL[dispatch.PDKind]
dispatch._EVAL[DifferencedComputedTorque] = dispatch._EVAL[dispatch.ComputedTorqueKind]
derivatives._DERIVATIVES[DifferencedPD] = derivatives._differenced
derivatives._DERIVATIVES[DifferencedComputedTorque] = derivatives._differenced
dispatch._EVAL[DifferencedOperationalSpace] = dispatch._EVAL[dispatch.OperationalSpaceKind]
derivatives._DERIVATIVES[DifferencedOperationalSpace] = derivatives._differenced
derivatives.MAY_BE_DIFFERENCED.update({DifferencedPD, DifferencedComputedTorque, DifferencedOperationalSpace})
_ANALYTICAL_TAG = problem_module.kind_tag
_DIFFERENCED = {dispatch.PDKind: DifferencedPD, dispatch.ComputedTorqueKind: DifferencedComputedTorque,
                dispatch.OperationalSpaceKind: DifferencedOperationalSpace}


def _differenced_tag(kind):
    return _DIFFERENCED[type(_ANALYTICAL_TAG(kind))]()


def use(differenced):
    """Build the next problems with the differenced tags or the analytical ones."""
    problem_module.kind_tag = _differenced_tag if differenced else _ANALYTICAL_TAG


def cases():
    panda = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")
    chain = dynamics.load_urdf(chain_urdf(10, damping=1e3))
    pq0 = np.array([0.5, 0.3, -0.4, -1.5, 0.3, 1.2, 0.0, 0.01, 0.03])
    pqt = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8, 0.02, 0.02])
    pd_panda = PD(pqt, np.r_[np.full(7, 100.0), 10.0, 10.0], np.r_[np.full(7, 10.0), 0.5, 0.5])
    cq0 = np.linspace(0.2, 1.5, 10)
    pd_chain = PD(np.zeros(10), 400.0, 40.0)

    def ct(model, q0, q1):
        t = np.linspace(0.0, 1.0, 5)
        Q = q0 + (q1 - q0) * (t[:, None] ** 2)
        V = 2 * (q1 - q0) * t[:, None]
        A = np.broadcast_to(2 * (q1 - q0), Q.shape)
        return ComputedTorque(t, Q, V, A, kp=100.0, kd=20.0)
    hand = dynamics.frame_placement(panda, pqt, "panda_hand")
    osc = Target("panda_hand", hand[:3, 3], hand[:3, :3], kp=100.0, kd=20.0, posture=pqt, posture_kp=10.0)
    return [("Panda PD", panda, pq0, pd_panda, 2.0), ("Panda computed torque", panda, pq0, ct(panda, pq0, pqt), 1.0),
            ("Panda operational space (pose + posture)", panda, pq0, osc, 1.0),
            ("chain10 stiff PD", chain, cq0, pd_chain, 0.5),
            ("chain10 stiff computed torque", chain, cq0, ct(chain, cq0, np.zeros(10)), 0.5)]


def jacobian_time(model, q0, source, n=200):
    """Best time of one robot_jacobian (of n in a row) at (q0, v = 0.1)."""
    ps = _passive(model, None, None, 1e4, 100.0, 1e-3)  # simulate's defaults
    p = robot_problem(model, ps, make_source(model, source), q0, np.zeros(1), ("q", "v"))
    nv = model.nv
    z = np.zeros(2 * nv + 2)
    z[nv:2 * nv] = 0.1
    J, st = np.empty((z.size, z.size)), new_stats()[0]
    robot_jacobian(p, 0.3, z, np.zeros(z.size), np.ones(z.size), 2 * nv, J, st)
    t = time.perf_counter()
    for _ in range(n):
        robot_jacobian(p, 0.3, z, np.zeros(z.size), np.ones(z.size), 2 * nv, J, st)
    return (time.perf_counter() - t) / n, J.copy()


def run_time(model, q0, source, T):
    t = time.perf_counter()
    tr = dynamics.simulate(model, q0, np.zeros(model.nv), T, torque=source, integrator="radau", rtol=1e-8,
                           atol=1e-8, sample_dt=T, error_estimate="none")
    return time.perf_counter() - t, tr


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default="", help="run the cases whose name contains this text")
    args = ap.parse_args()
    print("| case | Jacobian differenced (us) | analytical (us) | ratio | run differenced (s) | analytical (s) | "
          "ratio | Jacobians | largest difference of the final states |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, model, q0, source, T in cases():
        if args.only not in name:
            continue
        best = {True: [np.inf, np.inf], False: [np.inf, np.inf]}
        runs, Js = {}, {}
        for k in range(args.repeat + 1):  # the first round compiles
            for differenced in (False, True):
                use(differenced)
                tj, Js[differenced] = jacobian_time(model, q0, source)
                tr_time, runs[differenced] = run_time(model, q0, source, T)
                if k > 0:
                    best[differenced][0] = min(best[differenced][0], tj)
                    best[differenced][1] = min(best[differenced][1], tr_time)
        use(False)
        a, d = runs[False], runs[True]
        dx = max(np.abs(a.q[-1] - d.q[-1]).max(), np.abs(a.v[-1] - d.v[-1]).max())
        print(f"| {name} | {best[True][0] * 1e6:.1f} | {best[False][0] * 1e6:.1f} | "
              f"{best[True][0] / best[False][0]:.2f} | {best[True][1]:.3f} | {best[False][1]:.3f} | "
              f"{best[True][1] / best[False][1]:.2f} | {a.report['jacobian_evals']} / "
              f"{d.report['jacobian_evals']} | {dx:.1e} |", flush=True)


if __name__ == "__main__":
    main()
