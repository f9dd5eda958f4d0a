"""Error against run time for simulation (issue 3, sections 3 and 4): `python -m benchmarks.work_precision`.

Problems (all from URDFs: robots/ and example-robot-data, found at run time, never copied):

* ``2R``: the planar 2R arm of robots/planar_2r.urdf released from (90 deg, 45 deg), no torque, 10 s
  (chaotic: errors grow ~1e7x over the run, so no method gets below ~1e-9);
* ``Panda PD``: Panda (example-robot-data) under PD control to a posture, 5 s;
* ``chain20``: a 20-link pendulum chain falling from horizontal under gravity, 1 s (longer runs are chaotic
  beyond what a double-precision reference resolves);
* ``chain10 stiff``: a 10-link chain with joint damping 1e3 (time constants ~10 us), 0.5 s.

Each method runs over a range of tolerances (adaptive) or steps (fixed); the error is the max-norm of the
final (q, v) against a reference computed by our dop853 (radau for the stiff chain) at rtol = atol = 1e-13,
cross-checked against
Pinocchio's ABA + scipy DOP853 at 1e-13 (their difference is printed as the reference's own accuracy).
What users would use instead runs in the same process, on the same problems:

* Pinocchio's ``aba`` (URDF damping added as -d v, the PD law in Python) integrated by
  ``scipy.integrate.solve_ivp`` with DOP853 and Radau;
* MuJoCo (the URDF with visuals and collisions stripped; contacts, joint limits and equality constraints
  disabled; the PD law as MuJoCo joint springs/dampers, so it is evaluated inside every RK4 stage) stepped
  by ``mujoco.rollout`` (C loop, no Python per step) with RK4 and implicitfast at fixed steps.  Before
  timing, MuJoCo's accelerations are compared with ours at the initial state ("mj check").

Times are wall-clock seconds of one whole call (ours: ``simulate(..., error_estimate="none")``), best of 2
for runs under 2 s; the machine is shared, so the minimum is the least disturbed measurement.  Speed ratios
at matched error interpolate log(time) against log(error) on each method's lower envelope; ``ours`` is the
envelope of all our integrators.  Output: the markdown tables (printed and in benchmarks/out/
work_precision.md), the log-log plot benchmarks/out/work_precision.png, copied to docs/work_precision.png.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import math
import os
import re
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import dynamics
from dynamics.simulation import simulate, state_error
from dynamics.torques import PD

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "out"
DOCS = REPO / "docs"
ERROR_LEVELS = (1e-2, 1e-4, 1e-6, 1e-8)


def erd(rel: str) -> str:
    dist = importlib.metadata.distribution("example-robot-data")
    return str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots") / rel)


def chain_urdf(n, *, length=0.2, mass=1.0, inertia=1e-3, damping=0.0):
    """A serial chain of n revolute links swinging about y (a pendulum chain)."""
    parts = [f'<robot name="chain{n}"><link name="base"/>']
    for i in range(n):
        parts.append(
            f'<link name="link{i}"><inertial><origin xyz="0 0 {-length / 2}"/><mass value="{mass}"/>'
            f'<inertia ixx="{inertia}" ixy="0" ixz="0" iyy="{inertia}" iyz="0" izz="{inertia}"/></inertial></link>'
            f'<joint name="joint{i}" type="revolute"><parent link="{"base" if i == 0 else f"link{i - 1}"}"/>'
            f'<child link="link{i}"/><origin xyz="0 0 {0.0 if i == 0 else -length}"/><axis xyz="0 1 0"/>'
            f'<limit lower="-3.14" upper="3.14" effort="100" velocity="10"/>'
            f'<dynamics damping="{damping}" friction="0"/></joint>')
    return "".join(parts) + "</robot>"


@dataclass
class Problem:
    name: str
    urdf: str  # URDF text
    q0: np.ndarray
    v0: np.ndarray
    T: float
    pd: tuple | None = None  # (q_target, kp, kd)
    tols: tuple = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
    dts: tuple = (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)
    euler_dts: tuple = (1e-3, 1e-4, 1e-5)
    scipy_tols: tuple = (1e-4, 1e-6, 1e-8, 1e-10)
    scipy_explicit: bool = True
    model: object = None
    extra: dict = field(default_factory=dict)


def problems(quick=False):
    arm = (REPO / "robots" / "planar_2r.urdf").read_text()
    panda = Path(erd("panda_description/urdf/panda.urdf")).read_text()
    qt = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8, 0.02, 0.02])
    out = [
        Problem("2R released", arm, np.array([np.pi / 2, np.pi / 4]), np.zeros(2), 10.0),
        Problem("Panda PD", panda, np.array([0.5, 0.3, -0.4, -1.5, 0.3, 1.2, 0.0, 0.01, 0.03]), np.zeros(9), 5.0,
                pd=(qt, np.r_[np.full(7, 100.0), 10.0, 10.0], np.r_[np.full(7, 10.0), 0.5, 0.5])),
        Problem("chain20 falling", chain_urdf(20), np.r_[np.pi / 2, np.full(19, 0.05)], np.zeros(20), 1.0),
        Problem("chain10 stiff (damping 1e3)", chain_urdf(10, damping=1e3), np.linspace(0.2, 1.5, 10), np.ones(10),
                0.5, dts=(4e-6, 2e-6, 1e-6), euler_dts=(1e-6,), tols=(1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8),
                scipy_tols=(1e-3, 1e-6, 1e-9), scipy_explicit=False),
    ]
    if quick:
        for p in out:
            p.T = min(p.T, 1.0)
            p.tols = p.tols[::2]
            p.dts = p.dts[::2]
            p.euler_dts = p.euler_dts[:1]
            p.scipy_tols = p.scipy_tols[::2]
    for p in out:  # fingers independent, as SciPy + Pinocchio and MuJoCo load Panda here (no mimic coupling)
        p.model = dynamics.load_urdf(p.urdf, mimic="independent")
    return out


def timed(fn, repeat=2):
    """(result, best wall time); a single run when the first one takes more than 2 s."""
    best, out = math.inf, None
    for k in range(repeat):
        t = time.perf_counter()
        out = fn()
        dt = time.perf_counter() - t
        best = min(best, dt)
        if dt > 2.0:
            break
    return out, best


# -- ours --------------------------------------------------------------------------------------------------
def torque_of(p):
    return None if p.pd is None else PD(p.pd[0], p.pd[1], p.pd[2])


def run_ours(p, integrator, **kw):
    def go():
        return simulate(p.model, p.q0, p.v0, p.T, torque=torque_of(p), integrator=integrator, sample_dt=p.T,
                        error_estimate="none", max_steps=10 ** 8, **kw)
    tr, t = timed(go)
    return tr.q[-1], tr.v[-1], t, tr.report


# -- Pinocchio + scipy ------------------------------------------------------------------------------------
def pinocchio_rhs(p):
    import pinocchio as pin
    pm = pin.buildModelFromXML(p.urdf)
    pd = pm.createData()
    nv = pm.nv
    damping = np.array(p.model.damping)
    if p.pd is None:
        def f(t, y):
            q, v = y[:nv], y[nv:]
            return np.concatenate([v, pin.aba(pm, pd, q, v, -damping * v)])
    else:
        qt, kp, kd = p.pd

        def f(t, y):
            q, v = y[:nv], y[nv:]
            return np.concatenate([v, pin.aba(pm, pd, q, v, kp * (qt - q) - kd * v - damping * v)])
    return f


def run_scipy(p, method, tol):
    from scipy.integrate import solve_ivp
    f = pinocchio_rhs(p)
    nv = p.model.nv

    def go():
        return solve_ivp(f, (0.0, p.T), np.r_[p.q0, p.v0], method=method, rtol=tol, atol=tol * 1e-2)
    sol, t = timed(go)
    return sol.y[:nv, -1], sol.y[nv:, -1], t, {"rhs_evals": int(sol.nfev), "status": sol.status}


# -- MuJoCo -----------------------------------------------------------------------------------------------
def mujoco_from_urdf(urdf, integrator, dt, pd=None, damping=None, strip_mimic=False):
    """MuJoCo's own URDF compiler on ``urdf`` (visuals and collisions stripped; limits, contact and equalities
    off), at step dt with ``integrator`` ("RK4", "implicitfast" or "Euler"); pd = (q_target, kp, kd): a PD law as
    joint springs and extra damping on top of ``damping`` (passive forces, inside every stage)."""
    import mujoco
    # MuJoCo reports instability at large steps by a warning and a reset (it shows up as a large error);
    # the default handler would also write MUJOCO_LOG.TXT into the working directory
    mujoco.set_mju_user_warning(lambda msg: None)
    txt = re.sub(r"<visual>.*?</visual>|<collision>.*?</collision>", "", urdf, flags=re.S)
    if strip_mimic:
        txt = re.sub(r"<mimic[^>]*/>", "", txt)
    txt = txt.replace("</robot>", '<mujoco><compiler discardvisual="true" fusestatic="false" '
                                  'balanceinertia="false"/></mujoco></robot>')
    m = mujoco.MjModel.from_xml_string(txt)
    dis = mujoco.mjtDisableBit
    m.opt.disableflags |= dis.mjDSBL_LIMIT | dis.mjDSBL_CONTACT | dis.mjDSBL_EQUALITY
    m.opt.timestep = dt
    m.opt.integrator = {"RK4": mujoco.mjtIntegrator.mjINT_RK4, "Euler": mujoco.mjtIntegrator.mjINT_EULER,
                        "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST}[integrator]
    if pd is not None:
        qt, kp, kd = pd
        m.jnt_stiffness[:] = kp
        m.qpos_spring[:] = qt
        m.dof_damping[:] = np.asarray(damping) + kd
    return m


def mujoco_model(p, integrator, dt):
    return mujoco_from_urdf(p.urdf, integrator, dt, p.pd, p.model.damping)


def mujoco_check(p):
    """Max |qdd_mujoco - qdd_ours| at the initial state (both include damping and the PD law)."""
    import mujoco
    m = mujoco_model(p, "RK4", 1e-3)
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = p.q0, p.v0 + 0.1
    mujoco.mj_forward(m, d)
    v = p.v0 + 0.1
    tau = -np.asarray(p.model.damping) * v
    if p.pd is not None:
        tau = tau + p.pd[1] * (p.pd[0] - p.q0) - p.pd[2] * v
    return float(np.abs(d.qacc - dynamics.forward_dynamics(p.model, p.q0, v, tau)).max())


def run_mujoco(p, integrator, dt):
    import mujoco
    from mujoco import rollout
    m = mujoco_model(p, integrator, dt)
    d = mujoco.MjData(m)
    nsteps = int(round(p.T / dt))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    chunk = max(1, min(nsteps, 200_000 // max(1, m.nq)))

    def go():
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = p.q0, p.v0
        state = np.empty(mujoco.mj_stateSize(m, spec))
        mujoco.mj_getState(m, d, state, spec)
        left = nsteps
        while left > 0:
            k = min(chunk, left)
            states, _ = rollout.rollout(m, d, state[None, :], nstep=k)
            state = states[0, -1]
            left -= k
        return state
    state, t = timed(go)
    nq, nv = m.nq, m.nv
    return state[1:1 + nq], state[1 + nq:1 + nq + nv], t, {"steps": nsteps}


# -- the sweep ----------------------------------------------------------------------------------------------
def reference(p, log):
    qa, va, t, _ = run_ours(p, "dop853" if p.scipy_explicit else "radau", rtol=1e-13, atol=1e-13)
    cross = None
    try:
        qb, vb, _, _ = run_scipy(p, "DOP853" if p.scipy_explicit else "Radau", 1e-13)
        cross = max(state_error(p.model, qa, va, qb, vb))
    except ImportError:
        pass
    log(f"  reference: ours in {t:.2f} s; vs Pinocchio + scipy at 1e-13: "
        f"{'n/a' if cross is None else f'{cross:.1e}'}")
    return qa, va, cross


def sweep(p, log, skip_competitors=False):
    qr, vr, cross = reference(p, log)
    runs = []  # (family, label, setting, error, time, report)

    def add(family, label, setting, res):
        q, v, t, rep = res
        ok = np.all(np.isfinite(q)) and np.all(np.isfinite(v)) and rep.get("status", "ok") in ("ok", 0)
        err = max(state_error(p.model, q, v, qr, vr)) if ok else math.inf
        runs.append((family, label, setting, err, t, rep))
        log(f"  {label:<22} {setting:>10}  error {err:9.2e}  time {t:8.4f} s")

    for k, tol in enumerate(p.tols):
        for integ in ("rk45", "dop853", "radau", "auto"):
            if integ in ("rk45", "dop853") and not p.scipy_explicit and k > 0:
                continue  # explicit on the stiff problem: one run shows the cost (stability-bound steps)
            add("ours", f"ours {integ}", f"rtol {tol:.0e}", run_ours(p, integ, rtol=tol, atol=tol * 1e-2))
    for dt in p.dts:
        add("ours", "ours rk4", f"dt {dt:.0e}", run_ours(p, "rk4", dt=dt))
    for dt in p.euler_dts:
        add("ours", "ours euler", f"dt {dt:.0e}", run_ours(p, "euler", dt=dt))
    if not skip_competitors:
        try:
            import pinocchio  # noqa: F401
            for tol in p.scipy_tols:
                if p.scipy_explicit:
                    add("pin", "Pinocchio+DOP853", f"rtol {tol:.0e}", run_scipy(p, "DOP853", tol))
                add("pin", "Pinocchio+Radau", f"rtol {tol:.0e}", run_scipy(p, "Radau", tol))
        except ImportError:
            log("  (pinocchio not installed: skipped)")
        try:
            import mujoco  # noqa: F401
            p.extra["mj_check"] = mujoco_check(p)
            log(f"  mj check (max |qdd difference|): {p.extra['mj_check']:.1e}")
            for dt in p.dts:
                add("mj", "MuJoCo RK4", f"dt {dt:.0e}", run_mujoco(p, "RK4", dt))
                add("mj", "MuJoCo implicitfast", f"dt {dt:.0e}", run_mujoco(p, "implicitfast", dt))
        except ImportError:
            log("  (mujoco not installed: skipped)")
    return runs, cross


def envelope(points):
    """Lower-left Pareto front of (error, time): sorted by error, time decreasing as error grows."""
    pts = sorted((e, t) for e, t in points if np.isfinite(e) and e > 0)
    front = []
    for e, t in pts:
        if not front or t < front[-1][1]:
            front.append((e, t))
    return front


def time_at(front, err):
    """log-log interpolation of the time needed for ``err`` along an envelope, or None out of range."""
    if len(front) < 1:
        return None
    es = np.log([e for e, _ in front])
    ts = np.log([t for _, t in front])
    x = math.log(err)
    if x < es[0] - 1e-9 or x > es[-1] + 1e-9:
        return None
    if len(es) == 1:
        return float(np.exp(ts[0]))
    return float(np.exp(np.interp(x, es, ts)))


def ratio_table(name, runs, floor=0.0):
    """Speed ratios at the error levels that the reference resolves (>= 10x its own disagreement)."""
    labels = sorted({r[1] for r in runs if r[0] != "ours"})
    ours = envelope([(r[3], r[4]) for r in runs if r[0] == "ours"])
    lines = [f"| {name}: time of X / time of ours at equal error | " + " | ".join(f"{e:.0e}" for e in ERROR_LEVELS)
             + " |", "|---|" + "---|" * len(ERROR_LEVELS)]
    for lab in labels:
        fr = envelope([(r[3], r[4]) for r in runs if r[1] == lab])
        cells = []
        for e in ERROR_LEVELS:
            if e < 10 * floor:
                cells.append("(below ref.)")
                continue
            a, b = time_at(fr, e), time_at(ours, e)
            cells.append("-" if a is None or b is None else f"{a / b:.1f}x")
        lines.append(f"| {lab} | " + " | ".join(cells) + " |")
    return lines


def runs_table(name, runs):
    lines = [f"| {name} | setting | error | time (s) | rhs evals / steps |", "|---|---|---|---|---|"]
    for fam, lab, setting, err, t, rep in runs:
        work = rep.get("rhs_evals", rep.get("steps", ""))
        lines.append(f"| {lab} | {setting} | {err:.1e} | {t:.4f} | {work} |")
    return lines


def plot(all_runs, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    n = len(all_runs)
    fig, axes = plt.subplots(1, n, figsize=(5 * n, 4.4))
    styles = {"ours": "-o", "pin": "--s", "mj": ":^"}
    for ax, (name, runs) in zip(np.atleast_1d(axes), all_runs):
        for lab in dict.fromkeys(r[1] for r in runs):
            pts = sorted((r[4], r[3]) for r in runs if r[1] == lab and np.isfinite(r[3]) and r[3] > 0)
            if pts:
                fam = next(r[0] for r in runs if r[1] == lab)
                ax.loglog([t for t, _ in pts], [e for _, e in pts], styles[fam], label=lab, ms=4)
        ax.set_title(name)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("error of the final state")
        ax.grid(True, which="major", alpha=0.3)
    np.atleast_1d(axes)[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


# -- section 4: stiff and extreme cases --------------------------------------------------------------------
def extreme_cases(log):
    rows = ["| case | integrator | status | steps | error vs tight ref | error_estimate | wall (s) |",
            "|---|---|---|---|---|---|---|"]

    def case(name, model, q0, v0, T, integrator="auto", **kw):
        tr = simulate(model, q0, v0, T, integrator=integrator, rtol=1e-7, atol=1e-9, **kw)
        ref = simulate(model, q0, v0, T, integrator="radau", rtol=1e-12, atol=1e-13, error_estimate="none", **kw)
        err = max(state_error(model, tr.q[-1], tr.v[-1], ref.q[-1], ref.v[-1]))
        r = tr.report
        rows.append(f"| {name} | {integrator}{' -> ' + r['switches'][0]['to'] if r['switches'] else ''} | "
                    f"{r['status']} | {r['steps']} | {err:.1e} | {r['error_estimate']:.1e} | {r['wall_time_s']:.3f} |")
        log(rows[-1])
        return err, r["error_estimate"]

    ratios = []
    for d in (1e3, 1e4, 1e5):
        m = dynamics.load_urdf(chain_urdf(6, damping=d))
        ratios.append(case(f"6-link chain, damping {d:.0e}", m, np.linspace(0.2, 1.2, 6), np.ones(6), 1.0))
    arm = dynamics.load_urdf(str(REPO / "robots" / "planar_2r.urdf"))
    ratios.append(case("2R, limit springs hit at 8 rad/s", arm, [0.0, 2.9], [0.0, 8.0], 1.0, limits="spring",
                       limit_stiffness=1e5, limit_damping=1e3))
    m_tip = _tip_chain()
    ratios.append(case("1e-6 kg tip on 100 kg links", m_tip, [0.5, 0.0, 0.0, 1e-3], np.ones(4), 1.0))
    m = dynamics.load_urdf(chain_urdf(5, inertia=1e-9))
    ratios.append(case("5 links, inertias 1e-9", m, np.linspace(0.3, 1.0, 5), np.zeros(5), 1.0))
    m = dynamics.load_urdf(chain_urdf(5))
    ratios.append(case("5 links, v0 = 100 rad/s", m, np.linspace(0.3, 1.0, 5), np.full(5, 100.0), 0.05))
    ratios.append(case("5 links, near singular (aligned)", m, np.r_[1.0, np.full(4, 1e-6)], np.zeros(5), 1.0))
    # energy of a conservative 5-link chain over 10 s at tight tolerance
    tr = simulate(m, np.linspace(0.5, 1.5, 5), np.zeros(5), 10.0, integrator="rk45", rtol=1e-12, atol=1e-14,
                  error_estimate="none")
    rows.append(f"| 5 links, 10 s, energy drift at rtol 1e-12 | rk45 | {tr.report['status']} | "
                f"{tr.report['steps']} | drift {tr.report['energy_drift']:.1e} | - | {tr.report['wall_time_s']:.3f} |")
    log(rows[-1])
    # cost per step grows linearly with the number of links
    growth = ["| links | rk4 time per step (us) | per link (us) |", "|---|---|---|"]
    for n in (50, 100, 200, 500):
        m = dynamics.load_urdf(chain_urdf(n))
        tr, t = timed(lambda: simulate(m, np.full(n, 0.01), np.zeros(n), 0.02, integrator="rk4", dt=1e-3,
                                       error_estimate="none"), repeat=3)
        per = tr.report["wall_time_s"] / tr.report["steps"] * 1e6
        growth.append(f"| {n} | {per:.0f} | {per / n:.2f} |")
        log(growth[-1])
    worst = max(e / est for e, est in ratios if est)
    return rows, growth, worst


def _tip_chain():
    masses, inertias = [100, 100, 100, 1e-6], [1.0, 1.0, 1.0, 1e-9]
    parts = ['<robot name="tip"><link name="base"/>']
    for i, (mm, I) in enumerate(zip(masses, inertias)):
        parts.append(f'<link name="l{i}"><inertial><origin xyz="0 0 -0.15"/><mass value="{mm}"/><inertia ixx="{I}" '
                     f'ixy="0" ixz="0" iyy="{I}" iyz="0" izz="{I}"/></inertial></link><joint name="j{i}" '
                     f'type="continuous"><parent link="{"base" if i == 0 else f"l{i - 1}"}"/><child link="l{i}"/>'
                     f'<origin xyz="0 0 {0 if i == 0 else -0.3}"/><axis xyz="0 1 0"/></joint>')
    return dynamics.load_urdf("".join(parts) + "</robot>")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="short runs and fewer settings (a smoke test)")
    ap.add_argument("--no-competitors", action="store_true", help="only our integrators")
    args = ap.parse_args(argv)
    OUT.mkdir(parents=True, exist_ok=True)
    lines = []

    def log(s):
        print(s, flush=True)

    # compile once before timing anything
    warm = dynamics.load_urdf(chain_urdf(2))
    for integ, kw in (("rk45", {}), ("rk4", {"dt": 1e-2})):
        simulate(warm, [0.1, 0.1], [0, 0], 0.05, integrator=integ, **kw)
    all_runs = []
    header = [f"machine: {os.cpu_count()} cores, Python {sys.version.split()[0]}, numpy {np.__version__}"]
    for p in problems(args.quick):
        log(f"\n## {p.name} (nv = {p.model.nv}, {p.T:g} s)")
        runs, cross = sweep(p, log, args.no_competitors)
        all_runs.append((p.name, runs))
        lines += [f"\n### {p.name} (nv = {p.model.nv}, {p.T:g} s)", "",
                  f"reference: ours (dop853/radau at 1e-13); Pinocchio + scipy at 1e-13 differs by "
                  f"{'n/a' if cross is None else f'{cross:.1e}'}"
                  + (f"; MuJoCo vs ours, max |qdd| difference at t=0: {p.extra['mj_check']:.1e}"
                     if "mj_check" in p.extra else ""), ""]
        lines += ratio_table(p.name, runs, cross or 0.0) + [""] + runs_table(p.name, runs)
    png = OUT / "work_precision.png"
    plot(all_runs, png)
    DOCS.mkdir(exist_ok=True)
    if not args.quick:
        shutil.copy(png, DOCS / "work_precision.png")
    log("\n## stiff and extreme cases (rtol 1e-7 against radau at 1e-12)")
    rows, growth, worst = extreme_cases(log)
    lines += ["\n### Stiff and extreme cases (rtol 1e-7, atol 1e-9; reference: radau at rtol 1e-12)", ""] + rows
    lines += ["", f"worst true error / error_estimate over these cases: {worst:.2f}", "", "### Cost per step", ""]
    lines += growth
    text = "\n".join(header + lines) + "\n"
    (OUT / "work_precision.md").write_text(text)
    print("\n" + text)
    print(f"plot: {png}" + ("" if args.quick else f" (copied to {DOCS / 'work_precision.png'})"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
