"""The torque sources' analytical derivatives in the C++ core, the public functions around them, and Radau runs
that use them in their Newton matrix: `python -m benchmarks.source_derivatives`.

* the source's derivatives at one state (dtau/dq, dtau/dv): the core's binding (``_core.torque_source_derivatives``)
  and the public ``torque_source_derivatives`` and ``closed_loop_derivatives`` (the source's checks and
  construction included);
* a whole Radau run (rtol 1e-8), its Jacobians and steps.

(Until 2026-11-29 this compared with the numba kernels the core replaced; that comparison is in git's history.)
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import dynamics
from benchmarks.work_precision import chain_urdf, erd
from dynamics import _core
from dynamics.simulation.native import core_passive, core_source
from dynamics.torque_derivatives import _passive
from dynamics.torques import PD, ComputedTorque, Target, make_source


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
    """(core binding, public torque_source_derivatives, public closed_loop_derivatives) seconds a call at
    (t = 0.3, q0, v = 0.1)."""
    ps = _passive(model, None, None, 1e4, 100.0, 1e-3)  # simulate's defaults
    src = make_source(model, source)
    cps, csrc = core_passive(model, ps), core_source(model, src)
    q, v, nv = np.ascontiguousarray(q0, float), np.full(model.nv, 0.1), model.nv
    out = [np.empty((nv, nv)) for _ in range(2)]
    t_core = _best(lambda: _core.torque_source_derivatives(model.core, cps, csrc, 0.3, q, v, out[0], out[1]), n)
    t_public = _best(lambda: dynamics.torque_source_derivatives(model, source, 0.3, q, v), n)
    t_loop = _best(lambda: dynamics.closed_loop_derivatives(model, source, 0.3, q, v), n)
    return np.array([t_core, t_public, t_loop])


def run(model, q0, source, T):
    t = time.perf_counter()
    tr = dynamics.simulate(model, q0, np.zeros(model.nv), T, torque=source, integrator="radau", rtol=1e-8,
                           atol=1e-8, sample_dt=T, error_estimate="none")
    return time.perf_counter() - t, tr


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="best of N")
    args = ap.parse_args()
    print("| case | derivatives, core (us) | public torque_source_derivatives (us) | closed_loop_derivatives (us) | "
          "radau run (s) | Jacobians | steps |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, model, q0, source, T in cases():
        times = np.min([derivative_times(model, q0, source) for _ in range(args.repeat)], axis=0)
        best, tr = min((run(model, q0, source, T) for _ in range(args.repeat)), key=lambda x: x[0])
        r = tr.report
        print(f"| {name} | {1e6 * times[0]:.1f} | {1e6 * times[1]:.0f} | {1e6 * times[2]:.0f} | {best:.3f} | "
              f"{r['jacobian_evals']} | {r['steps']} |")


if __name__ == "__main__":
    main()
