"""The torque sources' analytical derivatives in the C++ core against numba's, and Radau runs on the core against
the numba simulation: `python -m benchmarks.source_derivatives`.

For a PD and a computed-torque source on Panda and on the stiff 10-link chain (damping 1e3, benchmarks
.work_precision's), and the operational-space controller (a pose target with a posture task) on Panda, in one
process, alternately (best of --repeat):

* the source's derivatives at one state (dtau/dq, dtau/dv): numba's kernel (``source_derivatives_into``, which the
  numba simulation's Jacobian still compiles, called from a compiled wrapper) against the core's
  (``_core.torque_source_derivatives``, sources and passive torques built beforehand), and the public
  ``dynamics.torque_source_derivatives`` / ``closed_loop_derivatives`` (argument checks and the source's
  construction included);
* a whole Radau run (rtol 1e-8) on the numba simulation (``DYNAMICS_SIM_NUMBA``'s path, the analytical source
  derivatives in its Newton matrix) and on the core's (which differenced the computed torque and the
  operational-space controller until they moved to the core).

Also prints each run's Jacobians and steps (numba / core) and the largest difference of the two final states.
The numba columns go when the numba simulation does.
"""

from __future__ import annotations

import argparse
import importlib
import time

import numpy as np
from numba import njit

import dynamics
from benchmarks.work_precision import chain_urdf, erd
from dynamics import _core
from dynamics.control.derivatives import source_derivatives_into
from dynamics.control.dispatch import kind_tag, source_workspace
from dynamics.control.registry import release_callable
from dynamics.simulation.native import core_passive, core_source
from dynamics.torque_derivatives import _passive
from dynamics.torques import PD, ComputedTorque, Target, make_source

simulate_module = importlib.import_module("dynamics.simulation.simulate")


@njit(cache=False)
def _numba_derivatives(tag, src, tree, ps, t, q, v, ws, dq, dv):
    return source_derivatives_into(tag, src, tree, ps, t, q, v, ws, dq, dv)


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


def _best(f, n):
    f()
    t = time.perf_counter()
    for _ in range(n):
        f()
    return (time.perf_counter() - t) / n


def derivative_times(model, q0, source, n=300):
    """(numba kernel, core binding, public torque_source_derivatives, public closed_loop_derivatives) seconds a call
    at (t = 0.3, q0, v = 0.1), and the largest difference of numba's and the core's results."""
    ps = _passive(model, None, None, 1e4, 100.0, 1e-3)  # simulate's defaults
    src = make_source(model, source)
    assert src.slot < 0
    tag, ws = kind_tag(src.kind), source_workspace(src, model.tree.parents.shape[0], model.nv)
    cps, csrc = core_passive(model, ps), core_source(model, src)
    q, v, nv = np.ascontiguousarray(q0, float), np.full(model.nv, 0.1), model.nv
    out = [np.empty((nv, nv)) for _ in range(4)]
    t_numba = _best(lambda: _numba_derivatives(tag, src, model.tree, ps, 0.3, q, v, ws, out[0], out[1]), n)
    t_core = _best(lambda: _core.torque_source_derivatives(model.core, cps, csrc, 0.3, q, v, out[2], out[3]), n)
    t_public = _best(lambda: dynamics.torque_source_derivatives(model, source, 0.3, q, v), n)
    t_loop = _best(lambda: dynamics.closed_loop_derivatives(model, source, 0.3, q, v), n)
    diff = max(np.abs(out[0] - out[2]).max(), np.abs(out[1] - out[3]).max())
    if src.slot >= 0:
        release_callable(src.slot)
    return np.array([t_numba, t_core, t_public, t_loop]), diff


def run(model, q0, source, T, numba):
    simulate_module._NUMBA_SIM = numba
    try:
        t = time.perf_counter()
        tr = dynamics.simulate(model, q0, np.zeros(model.nv), T, torque=source, integrator="radau", rtol=1e-8,
                               atol=1e-8, sample_dt=T, error_estimate="none")
        return time.perf_counter() - t, tr
    finally:
        simulate_module._NUMBA_SIM = False


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default="", help="run the cases whose name contains this text")
    args = ap.parse_args()
    print("| case | derivatives numba (us) | core (us) | ratio | public torque_source_derivatives (us) | "
          "closed_loop_derivatives (us) | run numba (s) | core (s) | ratio | Jacobians | steps | "
          "largest difference of the final states |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, model, q0, source, T in cases():
        if args.only not in name:
            continue
        best_d, best_r, runs = np.full(4, np.inf), {True: np.inf, False: np.inf}, {}
        for k in range(args.repeat + 1):  # the first round compiles
            d, diff = derivative_times(model, q0, source)
            for numba in (True, False):
                tr_time, runs[numba] = run(model, q0, source, T, numba)
                if k > 0:
                    best_r[numba] = min(best_r[numba], tr_time)
            if k > 0:
                best_d = np.minimum(best_d, d)
        a, b = runs[True], runs[False]
        dx = max(np.abs(a.q[-1] - b.q[-1]).max(), np.abs(a.v[-1] - b.v[-1]).max())
        us = best_d * 1e6
        print(f"| {name} | {us[0]:.1f} | {us[1]:.1f} | {us[0] / us[1]:.2f} | {us[2]:.1f} | {us[3]:.1f} | "
              f"{best_r[True]:.3f} | {best_r[False]:.3f} | {best_r[True] / best_r[False]:.2f} | "
              f"{a.report['jacobian_evals']} / {b.report['jacobian_evals']} | {a.report['steps']} / "
              f"{b.report['steps']} | {dx:.1e} |", flush=True)
        assert diff == 0.0, f"{name}: numba's and the core's source derivatives differ by {diff:.1e}"


if __name__ == "__main__":
    main()
