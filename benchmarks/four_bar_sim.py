"""Four-bar simulation: error against run time, and drift over time (issue 10, section 4):
`python -m benchmarks.four_bar_sim`.

The problem: the lectures' crank-rocker (robots/four_bar.urdf, closed by its 5-row hinge <loop>), passive (no
torque, no damping, gravity 9.81 m/s^2), 10 s from the documented initial state: theta1 = 0.2 rad, the loop
closed by ``assemble`` with the crank held, and the crank turning at 4 rad/s (``project_velocity`` of
(4, 0, 0)), the state of tests/test_constraints_simulate.py.  Samples every 10 ms (1001).

* error = max over the samples and the three joints of |q - q_ref| (rad);
* drift = the closure's position residual max |phi(q)| (m) and velocity residual max |Phi_q v| (m/s) at the
  samples, recomputed for every tool by our ``constraint_residual`` and ``constraint_jacobian``.

Reference: SciPy's DOP853 at rtol = atol = 1e-13 on the lectures' closed-form index-1 formula
(:func:`lectures_rhs`, no Baumgarte terms, code independent of ours), cross-checked against our dop853 at
1e-13 with projection and against SciPy DOP853 at 1e-13 on Pinocchio's constraintDynamics; the largest
difference over the run is printed as the reference's accuracy.

The tools, all from the same URDF numbers:

* ours: ``dynamics.simulate`` (Baumgarte (10, 10) 1/s, the default), methods auto, dop853, rk45, radau at
  rtol 1e-3 ... 1e-12 (atol = rtol / 100), and auto, dop853 with ``project=True``;
* SciPy + Pinocchio: ``solve_ivp`` (DOP853, RK45 at rtol 1e-3 ... 1e-12, Radau to 1e-10, atol = rtol / 100,
  t_eval the samples) over ``pin.constraintDynamics`` (a 3-D point closure, its Baumgarte corrector Kp = 100, Kd = 20,
  the same as ours; proximal mu = 1e-10: the planar loop's third row is redundant);
* MuJoCo: the MJCF written by :func:`mjcf` from the URDF (same masses, inertias, lengths, gravity, no
  damping, no contacts), the loop an ``<equality><connect site1 site2>`` constraint, stepped by
  ``mujoco.rollout`` (a C loop) with Euler (MuJoCo's default) and RK4 at fixed steps, with MuJoCo's default
  softness (solref (0.02, 1), solimp (0.9, 0.95, 0.001, 0.5, 2)) and with the stiffest it allows
  (solref (2 dt, 1): the time constant is clamped to >= 2 dt; solimp (0.9999, 0.9999, ...)).  A second table
  sweeps solref/solimp at dt = 1e-4 to show how close the soft closure gets to the rigid one.

Every run is timed in a round robin over all tools (one run of each in turn, ``--repeat`` rounds, best of
each), so that all tools see the same machine load; the load average is printed.  Output: the markdown
tables (printed and in benchmarks/out/four_bar_sim.md) and the plot docs/four_bar_sim.png (error against run
time; |phi| over time for one setting per tool).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

import dynamics
from dynamics import plot as plotting

from .work_precision import envelope, time_at

REPO = Path(__file__).resolve().parent.parent
URDF = REPO / "robots" / "four_bar.urdf"
OUT = REPO / "benchmarks" / "out"
PNG = REPO / "docs" / "four_bar_sim.png"
T_END, SAMPLE_DT, CRANK_SPEED = 10.0, 0.01, 4.0
BAUMGARTE = (10.0, 10.0)  # ours (alpha, beta) = Pinocchio's Kd = 2 alpha, Kp = beta^2
ERROR_LEVELS = (1e-1, 1e-2, 1e-4, 1e-6, 1e-8)
MJ_DEFAULT = ((0.02, 1.0), (0.9, 0.95, 0.001, 0.5, 2.0))  # MuJoCo's default solref, solimp
STIFF_IMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)


def initial_state(model):
    """The documented initial state: theta1 = 0.2 rad, the loop closed, the crank at 4 rad/s."""
    q0 = dynamics.assemble(model, np.array([0.2, 0.5, 1.5]), fixed=["theta1"])
    v0 = dynamics.project_velocity(model, q0, np.array([CRANK_SPEED, 0.0, 0.0]))
    return q0, v0


def sample_times():
    return np.linspace(0.0, T_END, int(round(T_END / SAMPLE_DT)) + 1)


# -- the lectures' closed form (the reference) ----------------------------------------------------------
class FourBar(NamedTuple):
    """The lectures' parameters, read from the URDF (lengths from the joint origins and the loop's points)."""

    l0: float
    l1: float
    l2: float
    l3: float
    m: tuple  # (m1, m2, m3) kg
    r: tuple  # centres of mass along each link (m)
    inertia: tuple  # about the centres of mass and the joint axis (kg m^2)
    g: float = 9.81


def four_bar_numbers(path=URDF) -> FourBar:
    root = ET.parse(path).getroot()
    joint = {j.get("name"): j for j in root.findall("joint")}
    link = {k.get("name"): k for k in root.findall("link")}
    loop = root.find("loop")

    def x(el):
        return float(el.get("xyz").split()[0])

    m, r, inertia = [], [], []
    for name in ("link1", "link2", "link3"):
        ine = link[name].find("inertial")
        m.append(float(ine.find("mass").get("value")))
        r.append(x(ine.find("origin")))
        inertia.append(float(ine.find("inertia").get("izz")))
    return FourBar(x(joint["phi1"].find("origin")), x(joint["theta2"].find("origin")), x(loop.find("link_a")),
                   x(loop.find("link_b")), tuple(m), tuple(r), tuple(inertia))


def lectures_rhs(p: FourBar):
    """x' = (qd, qdd) of M qdd = f - Phi_q^T (Phi_q M^-1 Phi_q^T)^-1 {Phi_q M^-1 f + Phi_q_dot qd}, f = -C qd - G,
    the lectures' M, C, G of the 2R + 1R tree and their two loop equations (no stabilisation)."""
    (m1, m2, m3), (r1, r2, r3), (i1, i2, i3) = p.m, p.r, p.inertia
    l0, l1, l2, l3, g = p.l0, p.l1, p.l2, p.l3, p.g

    def rhs(t, x):
        t1, t2, p1, d1, d2, dp = x
        c2, s2 = math.cos(t2), math.sin(t2)
        M = np.array([[i1 + i2 + m1 * r1 ** 2 + m2 * (l1 ** 2 + r2 ** 2 + 2 * l1 * r2 * c2),
                       i2 + m2 * (r2 ** 2 + l1 * r2 * c2), 0.0],
                      [i2 + m2 * (r2 ** 2 + l1 * r2 * c2), i2 + m2 * r2 ** 2, 0.0],
                      [0.0, 0.0, i3 + m3 * r3 ** 2]])
        h = -m2 * l1 * r2 * s2
        c1, s1, c12, s12, cp, sp = (math.cos(t1), math.sin(t1), math.cos(t1 + t2), math.sin(t1 + t2),
                                    math.cos(p1), math.sin(p1))
        f = -np.array([h * (2 * d1 * d2 + d2 ** 2) + (m1 * r1 + m2 * l1) * g * c1 + m2 * r2 * g * c12,
                       -h * d1 ** 2 + m2 * r2 * g * c12, m3 * r3 * g * cp])
        J = np.array([[-l1 * s1 - l2 * s12, -l2 * s12, l3 * sp], [l1 * c1 + l2 * c12, l2 * c12, -l3 * cp]])
        Jd_qd = np.array([-l1 * c1 * d1 ** 2 - l2 * c12 * (d1 + d2) ** 2 + l3 * cp * dp ** 2,
                          -l1 * s1 * d1 ** 2 - l2 * s12 * (d1 + d2) ** 2 + l3 * sp * dp ** 2])
        Minv = np.linalg.inv(M)
        lam = -np.linalg.solve(J @ Minv @ J.T, J @ Minv @ f + Jd_qd)
        return np.concatenate([x[3:], Minv @ (f + J.T @ lam)])
    return rhs


# -- MuJoCo: the same four-bar as MJCF ---------------------------------------------------------------------
def mjcf(path=URDF) -> str:
    """MJCF of the URDF's tree (bodies at the joints' origins, hinges about their axes, the same inertials),
    gravity 9.81 m/s^2 down, no damping, no geoms (so no contacts), and the <loop> as an <equality><connect>
    between two sites at the loop's points (site1/site2: the two points coincide, whatever the pose at
    compile time)."""
    root = ET.parse(path).getroot()
    links = {k.get("name"): k for k in root.findall("link")}
    children: dict = {}
    for j in root.findall("joint"):
        children.setdefault(j.find("parent").get("link"), []).append(j)
    loop = root.find("loop")
    sites = {loop.find(tag).get("name"): (f"loop_{tag[-1]}", loop.find(tag).get("xyz")) for tag in ("link_a", "link_b")}

    def attr(el, name, default="0 0 0"):
        return default if el is None or el.get(name) is None else el.get(name)

    def body(j):
        child = j.find("child").get("link")
        origin = j.find("origin")
        out = [f'<body name="{child}" pos="{attr(origin, "xyz")}" euler="{attr(origin, "rpy")}">']
        if j.get("type") in ("revolute", "continuous"):
            out.append(f'<joint name="{j.get("name")}" type="hinge" axis="{attr(j.find("axis"), "xyz", "1 0 0")}"/>')
        ine = links[child].find("inertial")
        if ine is not None:
            I = ine.find("inertia")
            full = " ".join(I.get(k, "0") for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
            if any(float(a) for a in attr(ine.find("origin"), "rpy").split()):
                raise ValueError(f"mjcf: link {child!r}: a rotated inertial frame is not handled")
            out.append(f'<inertial pos="{attr(ine.find("origin"), "xyz")}" mass="{ine.find("mass").get("value")}" '
                       f'fullinertia="{full}"/>')
        if child in sites:
            out.append(f'<site name="{sites[child][0]}" pos="{sites[child][1]}"/>')
        out += [body(c) for c in children.get(child, [])] + ["</body>"]
        return "".join(out)

    world = "".join(body(j) for j in children[root.find("link").get("name")])
    return (f'<mujoco model="{root.get("name")}"><compiler angle="radian" eulerseq="XYZ" balanceinertia="false"/>'
            f'<option gravity="0 0 -9.81"/><worldbody>{world}</worldbody>'
            f'<equality><connect name="{loop.get("name")}" site1="loop_a" site2="loop_b"/></equality></mujoco>')


def mujoco_model(xml, integrator, dt, solref, solimp):
    import mujoco
    mujoco.set_mju_user_warning(lambda msg: None)  # instability is seen as a large error, no MUJOCO_LOG.TXT
    m = mujoco.MjModel.from_xml_string(xml)
    m.opt.timestep = dt
    m.opt.integrator = {"Euler": mujoco.mjtIntegrator.mjINT_EULER, "RK4": mujoco.mjtIntegrator.mjINT_RK4}[integrator]
    m.eq_solref[0], m.eq_solimp[0] = solref, solimp
    return m


def mujoco_runner(xml, q0, v0, integrator, dt, solref, solimp):
    """A callable returning (q, v) at the samples: one mujoco.rollout over the whole run (C loop)."""
    import mujoco
    from mujoco import rollout
    m = mujoco_model(xml, integrator, dt, solref, solimp)
    d = mujoco.MjData(m)
    nsteps, stride = int(round(T_END / dt)), int(round(SAMPLE_DT / dt))
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(m, spec))

    def go():
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = q0, v0
        mujoco.mj_getState(m, d, state0, spec)
        states = rollout.rollout(m, d, state0[None, :], nstep=nsteps)[0][0, stride - 1::stride]
        return (np.vstack([q0, states[:, 1:1 + m.nq]]), np.vstack([v0, states[:, 1 + m.nq:1 + m.nq + m.nv]]),
                {"steps": nsteps})
    return go


def mujoco_check(xml, model, q, v):
    """(max |M_mujoco - M_ours|, max |bias_mujoco - bias_ours|, closure rows' residual at q, max |qacc - a_rigid|
    with the default softness and the stiffest): the model is the same, only the closure's softness differs."""
    import mujoco
    out = []
    for solref, solimp in (MJ_DEFAULT, ((2e-4, 1.0), STIFF_IMP)):
        m = mujoco_model(xml, "RK4", 1e-4, solref, solimp)
        d = mujoco.MjData(m)
        d.qpos[:], d.qvel[:] = q, v
        mujoco.mj_forward(m, d)
        out.append(float(np.abs(d.qacc - dynamics.constrained_forward_dynamics(model, q, v, np.zeros(3))[0]).max()))
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    return (float(np.abs(M - dynamics.mass_matrix(model, q)).max()),
            float(np.abs(d.qfrc_bias - dynamics.bias_forces(model, q, v)).max()), float(np.abs(d.efc_pos).max()), *out)


# -- SciPy + Pinocchio ------------------------------------------------------------------------------------
def pinocchio_rhs(model):
    """x' = (v, a) with a from pin.constraintDynamics: the loop as a 3-D point closure (its third row is
    redundant in the plane, hence proximal mu = 1e-10), Baumgarte Kp = beta^2, Kd = 2 alpha as ours."""
    import pinocchio as pin
    pm = pin.buildModelFromUrdf(str(URDF))  # Pinocchio orders the joints (phi1, theta1, theta2)
    order = np.array([list(model.joint_names).index(pm.names[i]) for i in range(1, pm.njoints)])
    pd = pm.createData()
    con = next(c for c in model.constraints if hasattr(c, "point_a"))
    fa, fb = pm.frames[pm.getFrameId(con.frame_a)], pm.frames[pm.getFrameId(con.frame_b)]
    rcm = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, pm, fa.parentJoint,
                                   fa.placement * pin.SE3(np.eye(3), np.array(con.point_a)), fb.parentJoint,
                                   fb.placement * pin.SE3(np.eye(3), np.array(con.point_b)), pin.LOCAL_WORLD_ALIGNED)
    rcm.m_baumgarte_parameters.Kp = BAUMGARTE[1] ** 2
    rcm.m_baumgarte_parameters.Kd = 2 * BAUMGARTE[0]
    cm, cd = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    cm.append(rcm)
    cd.append(rcm.createData())
    pin.initConstraintDynamics(pm, pd, cm, cd)
    prox = pin.ProximalSettings(1e-14, 1e-10, 50)
    tau, a = np.zeros(pm.nv), np.empty(pm.nv)

    def rhs(t, x):
        angles = x[:3][order]
        qp = np.column_stack([np.cos(angles), np.sin(angles)]).ravel()  # continuous joints: (cos, sin)
        a[order] = pin.constraintDynamics(pm, pd, qp, x[3:][order], tau, cm, cd, prox)
        return np.concatenate([x[3:], a])
    return rhs


def scipy_runner(rhs, q0, v0, method, tol, atol=None):
    from scipy.integrate import solve_ivp
    ts = sample_times()

    def go():
        sol = solve_ivp(rhs, (0.0, T_END), np.r_[q0, v0], method=method, rtol=tol,
                        atol=tol / 100 if atol is None else atol, t_eval=ts)
        if not sol.success:
            raise RuntimeError(f"solve_ivp {method} at {tol:g}: {sol.message}")
        return sol.y[:3].T, sol.y[3:].T, {"rhs_evals": int(sol.nfev)}
    return go


# -- ours ---------------------------------------------------------------------------------------------------
def ours_runner(model, q0, v0, integrator, tol, project=False, duration=T_END):
    def go():
        tr = dynamics.simulate(model, q0, v0, duration, integrator=integrator, rtol=tol, atol=tol / 100,
                               sample_dt=SAMPLE_DT, error_estimate="none", outputs=("q", "v"), project=project,
                               baumgarte=BAUMGARTE, max_steps=10 ** 7, progress=False)
        if tr.report["status"] != "ok":
            raise RuntimeError(f"simulate {integrator} at {tol:g}: {tr.report['status']}")
        return tr.q, tr.v, {"rhs_evals": tr.report["rhs_evals"], "steps": tr.report["steps"]}
    return go


# -- the sweep ----------------------------------------------------------------------------------------------
class Job(NamedTuple):
    tool: str  # "ours", "pin", "mj" (the plot's line style)
    label: str  # one curve
    setting: str
    go: Callable  # () -> (q (N, 3), v (N, 3), work dict) at the sample times


def jobs(model, q0, v0, xml, quick=False):
    tols = (1e-3, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12)
    dts = (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)
    if quick:
        tols, dts = tols[1::2], dts[::3]
    out = []
    for integ, project in (("auto", False), ("dop853", False), ("rk45", False), ("radau", False), ("auto", True),
                           ("dop853", True)):
        label = f"ours {integ}" + (" + project" if project else "")
        out += [Job("ours", label, f"rtol {tol:.0e}", ours_runner(model, q0, v0, integ, tol, project)) for tol in tols]
    rhs = pinocchio_rhs(model)
    for method in ("DOP853", "RK45", "Radau"):  # Radau at 1e-12: ~40 s a run here, left out
        out += [Job("pin", f"SciPy {method} + Pinocchio", f"rtol {tol:.0e}", scipy_runner(rhs, q0, v0, method, tol))
                for tol in tols if method != "Radau" or tol > 1e-11]
    for integ in ("Euler", "RK4"):
        for soft in ("default", "stiff"):
            for dt in dts:
                solref, solimp = MJ_DEFAULT if soft == "default" else ((2 * dt, 1.0), STIFF_IMP)
                out.append(Job("mj", f"MuJoCo {integ}, {soft} solref/solimp", f"dt {dt:.0e}",
                               mujoco_runner(xml, q0, v0, integ, dt, solref, solimp)))
    return out


class Result(NamedTuple):
    job: Job
    time: float  # best wall time over the rounds (s)
    error: float  # max over the samples of |q - q_ref| (rad); inf when the run failed or blew up
    drift: float  # max |phi| (m)
    drift_v: float  # max |Phi_q v| (m/s)
    phi_t: np.ndarray  # max |phi| per sample (N,)
    work: dict


def measure(model, q, v, q_ref):
    """(error, max |phi|, max |Phi_q v|, |phi| per sample); inf and NaNs when the run blew up."""
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))) or q.shape != q_ref.shape:
        return math.inf, math.inf, math.inf, np.full(len(q_ref), np.nan)
    q, v = np.ascontiguousarray(q), np.ascontiguousarray(v)
    phi = np.abs(dynamics.constraint_residual(model, q)).max(axis=1)
    vel = np.abs(np.einsum("bij,bj->bi", dynamics.constraint_jacobian(model, q), v)).max()
    return float(np.abs(q - q_ref).max()), float(phi.max()), float(vel), phi


def round_robin(model, job_list, q_ref, repeat, log):
    """Each job once per round, ``repeat`` rounds; best time per job (every tool sees the same load)."""
    best = [math.inf] * len(job_list)
    first: list = [None] * len(job_list)
    for r in range(repeat):
        for k, job in enumerate(job_list):
            t = time.perf_counter()
            try:
                res = job.go()
            except RuntimeError as exc:  # a failed solve is a point off the chart, said in the table
                res = (np.full_like(q_ref, np.nan), np.full_like(q_ref, np.nan), {"failed": str(exc)})
            best[k] = min(best[k], time.perf_counter() - t)
            if first[k] is None:
                first[k] = res
        log(f"  round {r + 1}/{repeat} done, load average {os.getloadavg()[0]:.2f}")
    results = []
    for job, t, (q, v, work) in zip(job_list, best, first):
        results.append(Result(job, t, *measure(model, q, v, q_ref), work))
        r = results[-1]
        log(f"  {job.label:<38} {job.setting:>10}  error {r.error:8.1e}  |phi| {r.drift:8.1e}  time {t:8.4f} s")
    return results


def softness_sweep(model, xml, q0, v0, q_ref, log, dt=1e-4):
    """MuJoCo RK4 at a small step over solref time constants and solimp widths: how rigid the closure gets."""
    rows = []
    for timeconst in (0.02, 0.002, 2 * dt):
        for imp in ((0.9, 0.95), (0.99, 0.99), (0.999, 0.999), (0.9999, 0.9999)):
            solimp = (*imp, 0.001, 0.5, 2.0)
            q, v, _ = mujoco_runner(xml, q0, v0, "RK4", dt, (timeconst, 1.0), solimp)()
            err, drift, drift_v, _ = measure(model, q, v, q_ref)
            rows.append((timeconst, imp, err, drift, drift_v))
            log(f"  solref ({timeconst:g}, 1) solimp {imp}: error {err:.1e}, |phi| {drift:.1e}, |Phi_q v| {drift_v:.1e}")
    return rows


def reference(model, q0, v0, log):
    """q_ref at the samples (SciPy DOP853 at 1e-13 on the closed form) and its distance to two other
    solutions at 1e-13: ours (dop853, projection) and SciPy DOP853 over Pinocchio."""
    from scipy.integrate import solve_ivp
    sol = solve_ivp(lectures_rhs(four_bar_numbers()), (0.0, T_END), np.r_[q0, v0], method="DOP853", rtol=1e-13,
                    atol=1e-13, t_eval=sample_times())
    if not sol.success:
        raise RuntimeError(f"the reference failed: {sol.message}")
    q_ref = sol.y[:3].T
    others = {"ours dop853 + project at 1e-13": ours_runner(model, q0, v0, "dop853", 1e-13, project=True),
              "SciPy DOP853 + Pinocchio at 1e-13": scipy_runner(pinocchio_rhs(model), q0, v0, "DOP853", 1e-13, 1e-13)}
    agree = {name: float(np.abs(go()[0] - q_ref).max()) for name, go in others.items()}
    ref_drift = float(np.abs(dynamics.constraint_residual(model, np.ascontiguousarray(q_ref))).max())
    log(f"  reference: {sol.nfev} evaluations, max |phi| {ref_drift:.1e}; against it: "
        + ", ".join(f"{k} {v:.1e}" for k, v in agree.items()))
    return q_ref, agree, ref_drift


def ratio_table(results, floor):
    """Time of X / time of ours (the envelope of all our runs) at equal error."""
    ours = envelope([(r.error, r.time) for r in results if r.job.tool == "ours"])
    lines = ["| time of X / time of ours at equal max error | " + " | ".join(f"{e:.0e}" for e in ERROR_LEVELS) + " |",
             "|---|" + "---|" * len(ERROR_LEVELS)]
    for label in dict.fromkeys(r.job.label for r in results if r.job.tool != "ours"):
        front = envelope([(r.error, r.time) for r in results if r.job.label == label])
        cells = []
        for e in ERROR_LEVELS:
            a, b = time_at(front, e), time_at(ours, e)
            cells.append("(below ref.)" if e < 10 * floor else "-" if a is None or b is None else f"{a / b:.1f}x")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return lines


def runs_table(results):
    lines = ["| tool | setting | max error (rad) | max \\|phi\\| (m) | max \\|Phi_q v\\| (m/s) | time (s) | work |",
             "|---|---|---|---|---|---|---|"]
    for r in results:
        work = r.work.get("failed") or ", ".join(f"{k} {v}" for k, v in r.work.items())
        lines.append(f"| {r.job.label} | {r.job.setting} | {r.error:.1e} | {r.drift:.1e} | {r.drift_v:.1e} | "
                     f"{r.time:.4f} | {work} |")
    return lines


def softness_table(rows, dt):
    lines = [f"| MuJoCo RK4, dt {dt:g}: solref (timeconst, 1) | solimp (dmin, dmax, 0.001, 0.5, 2) | max error (rad) "
             "| max \\|phi\\| (m) | max \\|Phi_q v\\| (m/s) |", "|---|---|---|---|---|"]
    for timeconst, imp, err, drift, drift_v in rows:
        lines.append(f"| {timeconst:g}{' (default)' if timeconst == 0.02 else ' (2 dt)' if timeconst == 2 * dt else ''}"
                     f" | {imp[0]:g}, {imp[1]:g}{' (default)' if imp == (0.9, 0.95) else ''} | {err:.1e} | "
                     f"{drift:.1e} | {drift_v:.1e} |")
    return lines


DRIFT_CURVES = (("ours dop853", "rtol 1e-08"), ("ours dop853 + project", "rtol 1e-08"),
                ("SciPy DOP853 + Pinocchio", "rtol 1e-08"), ("MuJoCo Euler, default solref/solimp", "dt 2e-03"),
                ("MuJoCo RK4, default solref/solimp", "dt 1e-03"), ("MuJoCo RK4, stiff solref/solimp", "dt 1e-04"))


def figure(results, path):
    """Left: max error against run time, one line per tool and setting family; right: |phi| over time."""
    plt = plotting.pyplot()
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.3))
    styles = {"ours": "-o", "pin": "--s", "mj": ":^"}
    for k, label in enumerate(dict.fromkeys(r.job.label for r in results)):
        pts = sorted((r.time, r.error) for r in results if r.job.label == label and np.isfinite(r.error))
        tool = next(r.job.tool for r in results if r.job.label == label)
        if pts:
            ax.loglog(*zip(*pts), styles[tool], ms=3, lw=1, label=label, color=plt.cm.tab20(k % 20))
    ax.set_xlabel("wall time of the 10 s run (s)")
    ax.set_ylabel("max |q - q_ref| over the run (rad)")
    ax.grid(alpha=0.3, which="major")
    ax.legend(fontsize=6, ncol=2)
    t = sample_times()
    for label, setting in DRIFT_CURVES:
        r = next((r for r in results if r.job.label == label and r.job.setting == setting), None)
        if r is not None and np.isfinite(r.drift):
            bx.semilogy(t[1:], np.maximum(r.phi_t[1:], 1e-17), lw=0.8, label=f"{label}, {setting}")
    bx.set_xlabel("time (s)")
    bx.set_ylabel("closure residual |phi(q)| (m)")
    bx.grid(alpha=0.3, which="major")
    bx.legend(fontsize=6, loc="center", bbox_to_anchor=(0.5, 0.6))  # the empty band between the tools' drifts
    fig.suptitle("Four-bar crank-rocker, passive, 10 s: error against run time, and drift", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=80)


def header(repeat, load_start):
    import mujoco
    import pinocchio
    import scipy
    load_end = os.getloadavg()
    return [f"Machine: {os.cpu_count()} logical CPUs shared by several engineers; load average (1, 5, 15 min) "
            f"{', '.join(f'{x:.2f}' for x in load_start)} at the start, {', '.join(f'{x:.2f}' for x in load_end)} at "
            f"the end.  Python {sys.version.split()[0]}, numpy {np.__version__}, SciPy {scipy.__version__}, "
            f"Pinocchio {pinocchio.__version__}, MuJoCo {mujoco.__version__}.  Every tool timed in a round robin, "
            f"best of {repeat} rounds."]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=5, help="rounds of the round robin (best time of each run)")
    ap.add_argument("--quick", action="store_true", help="fewer settings, one round, no copy into docs/")
    args = ap.parse_args(argv)
    repeat = 1 if args.quick else args.repeat
    load_start = os.getloadavg()

    def log(s):
        print(s, flush=True)

    model = dynamics.load_urdf(str(URDF))
    q0, v0 = initial_state(model)
    xml = mjcf()
    log(f"q0 = {np.array2string(q0, precision=17)}, v0 = {np.array2string(v0, precision=17)}")
    q_ref, agree, ref_drift = reference(model, q0, v0, log)
    floor = max(agree.values())
    check = mujoco_check(xml, model, q0, v0)
    for integ, project in (("auto", False), ("dop853", False), ("rk45", False), ("radau", False), ("auto", True),
                           ("dop853", True)):  # compile (or load from the cache) before timing
        ours_runner(model, q0, v0, integ, 1e-6, project, duration=0.05)()
    results = round_robin(model, jobs(model, q0, v0, xml, args.quick), q_ref, repeat, log)
    soft_dt = 1e-3 if args.quick else 1e-4
    log(f"MuJoCo softness sweep (RK4, dt {soft_dt:g}, untimed):")
    soft = softness_sweep(model, xml, q0, v0, q_ref, log, soft_dt)
    lines = ["# Four-bar simulation (`python -m benchmarks.four_bar_sim`)", ""] + header(repeat, load_start) + [
        "", f"Initial state q0 = {np.array2string(q0, precision=6)} rad, v0 = {np.array2string(v0, precision=6)} "
            "rad/s; passive, 10 s, samples every 10 ms.",
        f"Reference: SciPy DOP853 at rtol = atol = 1e-13 on the lectures' closed form (its max |phi| {ref_drift:.1e} m); "
        "against it, max |q difference| of " + ", ".join(f"{k}: {v:.1e}" for k, v in agree.items()) + " rad.",
        f"MuJoCo model check at q0: |M - M_ours| {check[0]:.1e}, |bias - bias_ours| {check[1]:.1e}, closure "
        f"residual {check[2]:.1e} m; |qacc - a_rigid| {check[3]:.2f} rad/s^2 with the default softness, "
        f"{check[4]:.1e} with the stiffest (dt 1e-4).", ""]
    lines += ratio_table(results, floor) + [""] + runs_table(results) + [""] + softness_table(soft, soft_dt)
    text = "\n".join(lines) + "\n"
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "four_bar_sim.md").write_text(text)
    png = OUT / "four_bar_sim.png" if args.quick else PNG
    figure(results, png)
    print("\n" + text)
    print(f"plot: {png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
