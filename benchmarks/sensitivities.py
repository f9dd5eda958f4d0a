"""What sensitivities cost a simulation: ``python -m benchmarks.sensitivities [--quick] [--repeat R]``.

Per robot and integrator, through the public API only: the wall time of ``dynamics.simulate(...,
sensitivities=True)`` (dx(T)/dx0, 2 nv columns, integrated with the state under the same error control) against
the same call without sensitivities, the two alternated, best of --repeat; and against 2 nv + 1 plain runs
(forward differences of x0: what a shooting method does without sensitivities; the best single run times
2 nv + 1).  Times are whole calls with ``error_estimate="none"``; the error estimate of S (the default ``rerun``
estimate, ``report["sensitivities"]["error_estimate"]``) comes from one more, untimed, call.

Robots: the double pendulum (planar 2R) under PD, a 12-link chain (damping 1e3: stiff), Panda under PD and, without
--quick, the README's ball dropped on the ground with contact (rk45 and radau, rtol 1e-6).  A standing robot with
contact is left out: Talos (nv 38) is beyond radau with sensitivities (76 columns make 5,852 components, over its
2,000); Go1 (nv 18) standing, with sensitivities, took 33 s for 0.1 s with rk45 (0.8 s without) and over 5 minutes
for 0.01 s with radau, on 2 shared cores.
Printed as a markdown table and written to benchmarks/out/sensitivities.md.
"""

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import dynamics
from dynamics.torques import PD

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests"))
from robots import chain_urdf, erd  # noqa: E402

OUT = Path(__file__).resolve().parent / "out" / "sensitivities.md"


#: the README's ball (a free body, dropped on the ground: bounces)
BALL = """<robot name="ball"><link name="ball"><inertial><mass value="0.2"/>
  <inertia ixx="2e-4" iyy="2e-4" izz="2e-4" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>"""


def cases(quick):
    """(name, model, q0, v0, duration, simulate's keywords, integrators)."""
    out = []
    two_r = dynamics.load_urdf(dynamics.robots.path("planar_2r"))
    out.append(("double pendulum, PD", two_r, np.array([0.3, 0.2]), np.array([0.0, 1.5]), 2.0,
                dict(torque=PD([0.5, -0.3], 8.0, 0.5), rtol=1e-8, atol=1e-10), ("rk45", "radau")))
    chain = dynamics.load_urdf(chain_urdf(12, damping=1e3))
    out.append(("chain12, damping 1e3 (stiff)", chain, np.linspace(0.2, 1.2, 12), np.ones(12), 0.5,
                dict(rtol=1e-6, atol=1e-8), ("radau",)))
    panda = dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")
    pq0 = panda.neutral() + 0.1
    out.append(("Panda, PD", panda, pq0, np.zeros(panda.nv), 0.5 if quick else 1.0,
                dict(torque=PD(pq0 + 0.2, 200.0, 20.0, tau_ff=dynamics.gravity_torques(panda, pq0 + 0.2)),
                     rtol=1e-8, atol=1e-10), ("rk45", "radau")))
    if not quick:
        ball = dynamics.load_urdf(BALL, floating_base=True)
        out.append(("README ball, contact (drop, bounces)", ball, np.array([0, 0, 0.3, 0, 0, 0, 1.0]),
                    np.array([0.5, 0, 0, 0, 0, 0]), 0.6,
                    dict(contact=dynamics.Contact(geometries=[dynamics.Sphere("ball", 0.05)]), rtol=1e-6, atol=1e-8),
                    ("rk45", "radau")))
    return out


def call(model, q0, v0, T, **kw):
    t = time.perf_counter()
    tr = dynamics.simulate(model, q0, v0, T, outputs=("q", "v"), progress=False, **kw)
    return time.perf_counter() - t, tr


def rows(quick, repeat):
    out = ["| case | integrator | nv | steps | without (s) | with sensitivities (s) | ratio with / without | "
           "2 nv + 1 runs (s) | ratio (2 nv + 1) / with | error estimate of S |",
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, m, q0, v0, T, kw, integrators in cases(quick):
        for integ in integrators:
            kw_i = dict(kw, integrator=integ, error_estimate="none")
            call(m, q0, v0, min(T, 0.01), sensitivities=True, **kw_i)  # first calls
            call(m, q0, v0, min(T, 0.01), **kw_i)
            plain, sens = np.inf, np.inf
            for _ in range(repeat):  # alternately
                w, tr_plain = call(m, q0, v0, T, **kw_i)
                plain = min(plain, w)
                w, tr = call(m, q0, v0, T, sensitivities=True, **kw_i)
                sens = min(sens, w)
            est = call(m, q0, v0, T, sensitivities=True, **dict(kw, integrator=integ))[1]
            est = est.report["sensitivities"]["error_estimate"]
            fd = (2 * m.nv + 1) * plain
            out.append(f"| {name} | {integ} | {m.nv} | {tr_plain.report['steps']} / {tr.report['steps']} | "
                       f"{plain:.4f} | {sens:.4f} | {sens / plain:.2f} | {fd:.3f} | {fd / sens:.1f} | "
                       + ("-" if est is None else f"{est:.1e}") + " |")
            print(out[-1], flush=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="no contact case, shorter Panda run, best of 1")
    ap.add_argument("--repeat", type=int, default=5, help="best of R alternated pairs (1 with --quick)")
    a = ap.parse_args(argv)
    repeat = 1 if a.quick else a.repeat
    # (rk45 on the bouncing ball says it looks stiff, a run's accuracy notes: the table is the point here)
    warnings.filterwarnings("ignore", category=dynamics.SimulationWarning)
    lines = ["## sensitivities: simulate with sensitivities=True against without, and against 2 nv + 1 runs", "",
             f"Whole calls, error_estimate='none', best of {repeat} alternated pairs; steps: without / with.", ""]
    lines += rows(a.quick, repeat)
    text = "\n".join(lines)
    print("\n" + text)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(text + "\n")


if __name__ == "__main__":
    main()
