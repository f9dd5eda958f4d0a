"""Forward simulation: q(t), v(t) from q0, v0 under joint torques, with an honest report.

The equations of motion (Featherstone 2008, eq. 1.1 solved by the ABA, :mod:`dynamics.aba`):

    M(q) v' + C(q, v) v + g(q) = tau_source(t, q, v) + tau_passive(q, v),      q' = v  (on the manifold)

tau_passive = damping + regularised Coulomb friction + optional limit springs (:mod:`dynamics.torques`).
The integrated state is z = [delta (nv), v (nv), W_source, W_passive]: delta is the chart coordinate of q
around the configuration at the start of the current step (:mod:`dynamics.integrate`, re-centred after every
step so free-flyer quaternions stay unit length), and the two quadratures integrate the power of the source
torques and of the passive torques, W' = v . tau, for the energy balance.

The whole loop (stepper, torque source, passive torques, ABA, output sampling) is one compiled
``numba`` function per call (``cache=True, nogil=True``); only a Python-callable torque leaves compiled code
(through ``numba.objmode``, once per right-hand-side evaluation).

Report (``Trajectory.report``, a JSON-serialisable dict)
--------------------------------------------------------
``integrator`` (the method asked for), ``switches`` (for ``auto``: each switch's time, from, to and reason),
``status`` ("ok", or why the run stopped early: "unstable: ..."), ``t_final``, ``steps`` (accepted),
``rejected_steps``, ``rhs_evals`` (ABA calls, Jacobian columns included), ``jacobian_evals``,
``lu_decompositions``, ``wall_time_s`` (the integration run alone), the error fields below, ``energy_drift``,
``energy_drift_max``, ``work_torque``, ``work_passive``, ``stability`` (fixed-step methods: dt * spectral radius
of the Jacobian at t0, and the method's stability limit), ``warnings``.  Non-finite numbers are reported as
None (strict JSON); the warnings say why (e.g. the error-estimate rerun failed).

How ``error_estimate`` is computed
----------------------------------
``error_estimate`` estimates the *global* error of the returned final state, as the max-norm over
``difference(q_final, q_true)`` (rad or m per velocity coordinate; :func:`dynamics.integrate.difference`)
and ``v_final - v_true`` (rad/s or m/s).  ``error_estimate_q`` and ``error_estimate_v`` are the two parts.
It is measured, not modelled, by a second run of the same method on the same problem (``error_estimate=
"rerun"``, the default):

* adaptive methods (``rk45``, ``dop853``, ``radau``, ``auto``): a second run with rtol and atol divided by 32.  With
  tolerance proportionality (global error ~ C tol^a, a in [0.8, 1] for these methods) the tighter run's error
  is 16-32x smaller, so ``|y(tol) - y(tol/32)|`` is the error of y(tol) to within ~6%.
* fixed-step methods (``euler``, ``rk4``, order p = 1, 4): a second run with dt/2, and Richardson's estimate
  ``|y(dt) - y(dt/2)| * 2^p / (2^p - 1)``.

The second run costs 1-3x the first and is timed separately (``error_estimate_wall_time_s``).  With
``error_estimate="local"`` the report gives instead the sum over accepted steps of the max-norm of the local
error estimates (adaptive methods only): cheap, but it can understate the global error of unstable or chaotic
dynamics, whose local errors grow.  ``"none"`` skips it (``error_estimate`` is None).

Energy balance
--------------
``energy_drift = |E(T) - E(0) - W_source(T) - W_passive(T)| / scale``, E = kinetic + potential energy,
scale = max(max_t K, max_t U - min_t U, |W_source|, |W_passive|) over the samples (independent of the
potential's arbitrary zero); ``energy_drift_max`` is the largest balance residual over all samples (samples
between steps come from dense output and are less accurate than step points).
"""

import math
import time
from typing import NamedTuple

import numpy as np

from . import integrators as I
from .aba import aba_into, forward_dynamics
from .aba import workspace as aba_workspace
from .energy import kinetic_energy_kernel, potential_energy_kernel
from ._numba import borrowed, inline_kernel, keep_alive, kernel
from .checks import real_number, vector
from .errors import InputError
from .configuration import chart_rate, difference, integrate_delta, retract
from .joints import JOINT_FREE
from .rnea import workspace as rnea_workspace
from .torques import Passive, make_source, passive_torques, release_callable, torque_eval

__all__ = ["simulate", "Trajectory", "INTEGRATORS"]


INTEGRATORS = ("euler", "rk4", "rk45", "radau", "auto", "dop853")
_ORDER = {"euler": 1, "rk4": 4}
# stability limits of the explicit methods along the negative real axis (|h lambda| <= limit)
_STABILITY = {"euler": 2.0, "rk4": 2.785, "rk45": 3.3}
NQUAD = 2  # W_source, W_passive


#: what a simulation can keep per sample (besides t)
OUTPUTS = ("q", "v", "tau")


class Trajectory(NamedTuple):
    """t (T,), q (T, nq), v (T, nv), tau (T, nv) applied source torques, report (dict)."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    report: dict


# ---------------------------------------------------------------------------------------------------
# the problem, as seen by the generic solvers (dynamics.integrators)
class RobotProblem(NamedTuple):
    """Everything the compiled loop needs; the njit functions below are attached as class attributes."""

    tree: object
    ps: object  # torques.Passive
    src: object  # torques.Source
    base: np.ndarray  # (nq,) configuration at the start of the current step (chart base)
    qbuf: np.ndarray  # (nq,) scratch
    tau_s: np.ndarray  # (nv,) scratch: source torques
    tau_p: np.ndarray  # (nv,) scratch: passive, then total torques
    ws_aba: tuple
    ws_src: tuple
    out_t: np.ndarray  # (T,)
    out_q: np.ndarray  # (T, nq)
    out_v: np.ndarray  # (T, nv)
    out_tau: np.ndarray  # (T, nv)
    out_w: np.ndarray  # (T, 2)
    count: np.ndarray  # (1,) samples written


@kernel
def _rhs(p, t, z, dz):
    tree, ps, src, base, qbuf, tau_s, tau_p, ws_aba, ws_src = p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8]
    nv = tau_s.shape[0]
    delta = z[:nv]
    v = z[nv:2 * nv]
    retract(tree, base, delta, qbuf)
    chart_rate(tree, qbuf, delta, v, dz[:nv])
    torque_eval(src, tree, ps, t, qbuf, v, ws_src, tau_s)
    passive_torques(ps, qbuf, v, tau_p)
    ps_ = 0.0
    pp_ = 0.0
    for k in range(nv):
        ps_ += v[k] * tau_s[k]
        pp_ += v[k] * tau_p[k]
        tau_p[k] += tau_s[k]  # tau_p now holds the total joint torque
    if aba_into(tree, qbuf, v, tau_p, ps.gravity, ps.f_ext, ws_aba, dz[nv:2 * nv]) >= 0:
        dz[nv:2 * nv] = np.nan  # singular articulated inertia
    dz[2 * nv] = ps_
    dz[2 * nv + 1] = pp_


@kernel
def _rebase(p, z, dz, mag):
    tree, base, qbuf = p[0], p[3], p[4]
    nv = p[5].shape[0]
    retract(tree, base, z[:nv], qbuf)
    base[:] = qbuf
    z[:nv] = 0.0
    chart_rate(tree, base, z[:nv], z[nv:2 * nv], dz[:nv])
    for i in range(tree.jtype.shape[0]):
        k = tree.v_idx[i]
        if tree.jtype[i] == JOINT_FREE:
            for r in range(3):
                mag[k + r] = abs(base[tree.q_idx[i] + r])
                mag[k + 3 + r] = 0.0
        else:
            mag[k] = abs(base[tree.q_idx[i]])


@kernel
def _euler_config(p, z, h):
    nv = p[5].shape[0]
    integrate_delta(p[0], p[3], z[nv:2 * nv], h, z[:nv])


@kernel
def _emit(p, j, t, z):
    """Write sample j.  An output the caller did not ask for has zero rows: it is neither kept nor, for the
    torques, computed."""
    tree, ps, src, base, qbuf, ws_src = p[0], p[1], p[2], p[3], p[4], p[8]
    out_t, out_q, out_v, out_tau, out_w, count = p[9], p[10], p[11], p[12], p[13], p[14]
    nv = out_v.shape[1]
    out_t[j] = t
    q = out_q[j] if out_q.shape[0] > 0 else qbuf  # qbuf is free between right-hand-side evaluations
    retract(tree, base, z[:nv], q)
    if out_v.shape[0] > 0:
        out_v[j] = z[nv:2 * nv]
    if out_tau.shape[0] > 0:
        torque_eval(src, tree, ps, t, q, z[nv:2 * nv], ws_src, out_tau[j])
    out_w[j] = z[2 * nv:]
    count[0] = j + 1


@kernel
def _problem(tree, ps, src, base, out_t, out_q, out_v, out_tau, out_w, count):
    nv = out_v.shape[1]
    nb = tree.parents.shape[0]
    return RobotProblem(tree, ps, src, base, np.empty(base.shape[0]), np.empty(nv), np.empty(nv),
                        aba_workspace(nb, nv), (rnea_workspace(nb), np.empty((4, nv))), out_t, out_q, out_v,
                        out_tau, out_w, count)


RobotProblem.rhs = _rhs
RobotProblem.rebase = _rebase
RobotProblem.euler_config = _euler_config
RobotProblem.emit = _emit


SPECTRAL_RADIUS = -1  # _run's "method" for: only estimate the spectral radius of the Jacobian at (t0, z)


@kernel
def _run(tree, ps, src, method, z, base, t0, t_end, dt, out_t, iopt, fopt, istats, fstats, switch_log,
         out_q, out_v, out_tau, out_w, count):
    """The compiled integration loop: picks the solver and runs it to t_end (one compiled entry point, so
    the right-hand side is compiled once per process and cached on disk)."""
    owner = _problem(tree, ps, src, base, out_t, out_q, out_v, out_tau, out_w, count)
    p = borrowed(owner)  # no reference counting per right-hand side (I.borrowed); owner is pinned below
    status = _solve(p, method, z, t0, t_end, dt, out_t, iopt, fopt, istats, fstats, switch_log)
    keep_alive(owner)
    return status


@inline_kernel
def _solve(p, method, z, t0, t_end, dt, out_t, iopt, fopt, istats, fstats, switch_log):
    if method == SPECTRAL_RADIUS:
        n = z.shape[0]
        nv = (n - NQUAD) // 2
        f0 = np.empty(n)
        _rhs(p, t0, z, f0)
        J = np.empty((n, n))
        I.fd_jacobian(p, t0, z, f0, np.zeros(n), 2 * nv, J, istats)
        fstats[0] = I.spectral_radius(J, 2 * nv)
        return 0
    if method == I.EULER or method == I.RK4:
        return I.solve_fixed(p, method, z, t0, t_end, dt, out_t, iopt, fopt, istats, fstats)
    return I.solve_adaptive(p, method, z, t0, t_end, out_t, iopt, fopt, istats, fstats, switch_log)


def _spectral_radius(model, ps, src, q0, v0):
    nv = model.nv
    z = np.zeros(2 * nv + NQUAD)
    z[nv:2 * nv] = v0
    fstats = np.zeros(8)
    _run(model.tree, ps, src, SPECTRAL_RADIUS, z, q0.copy(), 0.0, 0.0, 0.0, np.zeros(1), np.zeros(8, np.int64),
         np.zeros(8), np.zeros(8, np.int64), fstats, np.zeros((I.MAX_SWITCHES, 4)), np.zeros((1, model.nq)),
         np.zeros((1, nv)), np.zeros((1, nv)), np.zeros((1, NQUAD)), np.zeros(1, np.int64))
    return float(fstats[0])


@kernel
def _energies(tree, Q, V, gravity, K, U):
    tree = borrowed(tree)  # the caller owns the model; one kernel call per sample without atomics
    for j in range(Q.shape[0]):
        K[j] = kinetic_energy_kernel(tree, Q[j], V[j])
        U[j] = potential_energy_kernel(tree, Q[j], gravity)


@kernel
def _state_error(tree, q1, v1, q2, v2):
    d = np.empty(v1.shape[0])
    difference(tree, q2, q1, d)
    eq = 0.0
    ev = 0.0
    for k in range(d.shape[0]):
        eq = max(eq, abs(d[k]))
        ev = max(ev, abs(v1[k] - v2[k]))
    return eq, ev


def state_error(model, q1, v1, q2, v2):
    """(max |q1 - q2| on the manifold, max |v1 - v2|) between two states (used by tests and benchmarks)."""
    return _state_error(model.tree, np.ascontiguousarray(q1, float), np.ascontiguousarray(v1, float),
                        np.ascontiguousarray(q2, float), np.ascontiguousarray(v2, float))


# ---------------------------------------------------------------------------------------------------
# input checks
def _check_q(model, q0, warnings):
    q = vector("q0", q0, model.nq)
    tree = model.tree
    for i, code in enumerate(tree.jtype):
        if code == JOINT_FREE:
            k = int(tree.q_idx[i]) + 3
            nrm = float(np.linalg.norm(q[k:k + 4]))
            if nrm < 1e-6:
                raise InputError(f"q0: the quaternion q0[{k}:{k + 4}] of joint {model.joint_names[i]!r} is zero")
            if abs(nrm - 1.0) > 1e-6:
                warnings.append(f"q0: quaternion of joint {model.joint_names[i]!r} had norm {nrm:.6g}; normalised")
            q[k:k + 4] /= nrm
    return q


def _qpos_map(model):
    qpos = np.full(model.nv, -1, np.int64)
    tree = model.tree
    for i, code in enumerate(tree.jtype):
        if code != JOINT_FREE:
            qpos[tree.v_idx[i]] = tree.q_idx[i]
    return qpos


# ---------------------------------------------------------------------------------------------------
def _one_run(model, ps, src, method, q0, v0, duration, dt, out_t, rtol, atol, h0, max_steps, blowup,
             outputs=OUTPUTS):
    """One compiled run.  Returns (q, v, tau, t, W, count, istats, fstats, switch_log, wall, zfinal, base)."""
    nv, nq = model.nv, model.nq
    T = out_t.shape[0]
    out_q = np.zeros((T if "q" in outputs else 0, nq))
    out_v = np.zeros((T if "v" in outputs else 0, nv))
    out_tau = np.zeros((T if "tau" in outputs else 0, nv))
    out_w = np.zeros((T, NQUAD))
    count = np.zeros(1, np.int64)
    z = np.zeros(2 * nv + NQUAD)
    z[nv:2 * nv] = v0
    base = q0.copy()
    iopt = np.zeros(8, np.int64)
    iopt[I.I_NC] = nv
    iopt[I.I_NVEL] = nv
    iopt[I.I_NE] = 2 * nv
    iopt[I.I_MAXSTEPS] = max_steps
    if dt is not None and method in (I.EULER, I.RK4):
        iopt[I.I_NSTEPS] = max(1, math.ceil(duration / dt * (1 - 1e-12))) if duration > 0 else 0
    fopt = np.zeros(8)
    fopt[I.F_RTOL] = rtol
    fopt[I.F_ATOL] = atol
    fopt[I.F_H0] = h0 if h0 else 0.0
    fopt[I.F_HMAX] = np.inf
    fopt[I.F_BLOWUP] = blowup
    istats = np.zeros(8, np.int64)
    fstats = np.full(8, np.nan)
    switch_log = np.zeros((I.MAX_SWITCHES, 4))
    tic = time.perf_counter()
    _run(model.tree, ps, src, method, z, base, 0.0, float(duration), float(dt or 0.0), out_t, iopt, fopt,
         istats, fstats, switch_log, out_q, out_v, out_tau, out_w, count)
    wall = time.perf_counter() - tic
    qf = np.empty(nq)
    retract(model.tree, base, z[:nv], qf)
    return dict(q=out_q, v=out_v, tau=out_tau, t=out_t, w=out_w, count=int(count[0]), istats=istats,
                fstats=fstats, switch_log=switch_log, wall=wall, qf=qf, vf=z[nv:2 * nv].copy())


def _sample_times(duration, dt, sample_dt, fixed):
    if sample_dt is None:
        if fixed:
            n = max(1, math.ceil(duration / dt * (1 - 1e-12))) if duration > 0 else 0
            t = np.minimum(np.arange(n + 1) * dt, duration)
            t[-1] = duration
            return t
        sample_dt = duration / 1000 if duration > 0 else 1.0
    n = math.floor(duration / sample_dt * (1 + 1e-12))
    t = np.arange(n + 1) * sample_dt
    t = t[t < duration * (1 - 1e-12)] if duration > 0 else t[:1]
    return np.append(t, duration) if duration > 0 else t


def simulate(model, q0, v0, duration, *, torque=None, integrator="auto", rtol=1e-6, atol=1e-8, dt=None,
             sample_dt=None, gravity=None, max_steps=1_000_000, limits=None, limit_stiffness=1e4,
             limit_damping=100.0, friction_eps=1e-3, error_estimate="rerun", outputs=OUTPUTS):
    """Simulate the robot from (q0, v0) for ``duration`` seconds; returns a :class:`Trajectory`.

    torque: None, an (nv,) constant, :class:`dynamics.torques.Table`, :class:`~dynamics.torques.PD`,
        :class:`~dynamics.torques.ComputedTorque`, or a callable f(t, q, v) -> (nv,) (module docs).
    integrator: "euler" | "rk4" (fixed step ``dt``, required) | "rk45" | "dop853" | "radau" | "auto" (adaptive,
        ``rtol`` and ``atol`` on each component of (q, v); ``dt`` if given is the first step).
    sample_dt: output spacing (the last sample is always t = duration).  Default: every step for fixed-step
        methods, duration/1000 for adaptive ones (dense output between steps).
    gravity: (3,) world gravity, default ``model.gravity``.  max_steps: budget of attempted steps.
    limits: None or "spring" (Hunt-Crossley spring-damper at the URDF position limits, ``limit_stiffness``
        N m/rad, ``limit_damping`` N m s/rad^2).  friction_eps: velocity scale of the regularised Coulomb
        friction.  error_estimate: "rerun" (default), "local" or "none" (module docs).
    outputs: which of "q", "v", "tau" to keep per sample (``t`` always); the others come back as empty
        (0, n) arrays and are not computed (the applied torques) or stored.  Without q and v per sample the
        energy balance is taken between the first and last states only (``energy_drift_max`` is None).

    Raises InputError for bad arguments and when the step budget is exceeded; a run that goes unstable
    stops, returns the samples up to the failure and says so in ``report["status"]`` and ``warnings``.
    """
    warnings = []
    if not hasattr(model, "tree") or not hasattr(model, "nv"):
        raise InputError(f"model: expected a dynamics.Model, got {type(model).__name__}")
    if integrator not in INTEGRATORS:
        raise InputError(f"integrator: expected one of {INTEGRATORS}, got {integrator!r}")
    q0 = _check_q(model, q0, warnings)
    v0 = vector("v0", v0, model.nv)
    duration = real_number("duration", duration, lo=0.0)
    rtol = real_number("rtol", rtol, lo=1e-14, hi=1.0)
    atol = real_number("atol", atol, lo=0.0)
    fixed = integrator in ("euler", "rk4")
    dt = real_number("dt", dt, lo=0.0, lo_open=True, allow_none=True)
    if fixed and dt is None:
        raise InputError(f"dt: required (> 0) for the fixed-step integrator {integrator!r}")
    sample_dt = real_number("sample_dt", sample_dt, lo=0.0, lo_open=True, allow_none=True)
    g = model.gravity if gravity is None else gravity
    g = vector("gravity", g, 3)
    if isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or max_steps < 1:
        raise InputError(f"max_steps: expected a positive int, got {max_steps!r}")
    if limits not in (None, "spring"):
        raise InputError(f"limits: expected None or 'spring', got {limits!r}")
    limit_stiffness = real_number("limit_stiffness", limit_stiffness, lo=0.0)
    limit_damping = real_number("limit_damping", limit_damping, lo=0.0)
    friction_eps = real_number("friction_eps", friction_eps, lo=0.0, lo_open=True)
    if isinstance(outputs, str) or not set(outputs) <= set(OUTPUTS):
        raise InputError(f"outputs: expected a subset of {OUTPUTS}, got {outputs!r}")
    outputs = tuple(o for o in OUTPUTS if o in outputs)
    if error_estimate not in ("rerun", "local", "none"):
        raise InputError(f"error_estimate: expected 'rerun', 'local' or 'none', got {error_estimate!r}")
    if fixed:
        nsteps = math.ceil(duration / dt * (1 - 1e-12)) if duration > 0 else 0
        if nsteps > max_steps:
            raise InputError(f"max_steps: dt={dt:g} needs {nsteps} steps over {duration:g} s, more than "
                             f"max_steps={max_steps}")
    out_t = _sample_times(duration, dt, sample_dt, fixed)

    # a joint that moves no mass makes M singular: say which, now, rather than NaN in the first step
    forward_dynamics(model, q0, v0, np.zeros(model.nv), gravity=g)
    ps = Passive(np.ascontiguousarray(model.damping, float), np.ascontiguousarray(model.friction, float),
                 friction_eps, 1 if limits == "spring" else 0, np.ascontiguousarray(model.lower, float),
                 np.ascontiguousarray(model.upper, float), _qpos_map(model), limit_stiffness, limit_damping,
                 g, np.zeros((0, 6)))
    src = make_source(model, torque)
    method = INTEGRATORS.index(integrator)
    blowup = max(1e6, 1e4 * float(np.max(np.abs(v0), initial=0.0)))
    try:
        report = {"integrator": integrator, "rtol": rtol if not fixed else None,
                  "atol": atol if not fixed else None, "dt": dt}
        stability = None
        if fixed and duration > 0:
            rho = _spectral_radius(model, ps, src, q0, v0)
            stability = {"dt_times_spectral_radius": dt * rho, "limit": _STABILITY[integrator],
                         "spectral_radius": rho}
            if dt * rho > _STABILITY[integrator]:
                warnings.append(f"dt={dt:g} exceeds the stability limit of {integrator} for this problem at t=0 "
                                f"(dt * spectral radius = {dt * rho:.3g} > {_STABILITY[integrator]}): expect "
                                f"blow-up; use dt < {_STABILITY[integrator] / rho:.3g} or integrator='radau'")
        run = _one_run(model, ps, src, method, q0, v0, duration, dt, out_t, rtol, atol, dt if not fixed else 0,
                       max_steps, blowup, outputs)
        ist, fst = run["istats"], run["fstats"]
        status = I.STATUS_NAMES[ist[I.S_STATUS]]
        t_final = float(fst[I.FS_T]) if duration > 0 else 0.0
        if status == "max_steps":
            raise InputError(f"max_steps: step budget of {max_steps} exhausted at t={t_final:.6g} s of "
                             f"{duration:g} s; raise max_steps, loosen rtol/atol, or use integrator='radau' if "
                             "the problem is stiff")
        ok = status == "ok"
        if not ok:
            why = {"nonfinite": "a NaN/inf appeared in the state or its derivative",
                   "blowup": f"a joint velocity exceeded {blowup:.3g}",
                   "step_too_small": "the step size collapsed below the time resolution"}[status]
            status = f"unstable: {why} at t={t_final:.6g} s"
            warnings.append(f"simulation stopped early, {status}; the trajectory ends at the last good sample")
            if fixed and stability and stability["dt_times_spectral_radius"] <= stability["limit"]:
                warnings.append(f"{integrator}: consider a smaller dt or integrator='radau'")
        if integrator == "rk45" and fst[I.FS_STIFF_T] >= 0:
            warnings.append(f"rk45: the problem looks stiff from t={fst[I.FS_STIFF_T]:.6g} s (h*|lambda| > 3.25 on "
                            "15 accepted steps, DOPRI5's test); integrator='radau' or 'auto' will be cheaper")
        switches = []
        for k in range(int(ist[I.S_NSWITCH])):
            ts, to, why, val = run["switch_log"][k]
            to = I.METHOD_NAMES[int(to)]
            if int(why) == I.SWITCH_STIFF:
                reason = f"stiffness detected: h*|lambda| = {val:.3g} > 3.25 on 15 accepted rk45 steps"
            else:
                reason = f"no longer stiff: h*rho(J) = {val:.3g} < 2 on 20 accepted radau steps"
            switches.append({"t": float(ts), "from": "radau" if to == "rk45" else "rk45", "to": to,
                             "reason": reason})

        cnt = run["count"]
        t, q, v, tau, w = run["t"][:cnt], run["q"][:cnt], run["v"][:cnt], run["tau"][:cnt], run["w"][:cnt]
        report.update({
            "status": status,
            "t_final": t_final,
            "switches": switches,
            "steps": int(ist[I.S_STEPS]),
            "rejected_steps": int(ist[I.S_REJECTED]),
            "rhs_evals": int(ist[I.S_NFEV]),
            "jacobian_evals": int(ist[I.S_NJEV]),
            "lu_decompositions": int(ist[I.S_NLU]),
            "wall_time_s": run["wall"],
        })
        if stability is not None:
            report["stability"] = stability

        # -- error estimate of the final state
        est = est_q = est_v = None
        est_wall = 0.0
        method_note = error_estimate
        if error_estimate == "rerun" and ok and duration > 0:
            if fixed:
                if 2 * math.ceil(duration / dt) > max_steps:
                    warnings.append("error_estimate: the dt/2 rerun would exceed max_steps; no estimate")
                    method_note = "none"
                else:
                    r2 = _one_run(model, ps, src, method, q0, v0, duration, dt / 2, np.array([0.0]), rtol, atol, 0,
                                  max_steps, blowup)
                    p_ = _ORDER[integrator]
                    factor = 2 ** p_ / (2 ** p_ - 1)
            else:
                r2 = _one_run(model, ps, src, method, q0, v0, duration, None, np.array([0.0]), max(rtol / 32, 1e-14),
                              atol / 32, 0, 4 * max_steps, blowup)
                factor = 1.0
            if method_note == "rerun":
                est_wall = r2["wall"]
                if r2["istats"][I.S_STATUS] != I.OK:
                    est = est_q = est_v = float("inf")
                    warnings.append("error_estimate: the tighter rerun failed "
                                    f"({I.STATUS_NAMES[r2['istats'][I.S_STATUS]]}); estimate set to inf")
                else:
                    eq, ev = _state_error(model.tree, run["qf"], run["vf"], r2["qf"], r2["vf"])
                    est_q, est_v = eq * factor, ev * factor
                    est = max(est_q, est_v)
        elif error_estimate == "local" and not fixed:
            est = float(fst[I.FS_LOCAL_ERR])
        elif error_estimate == "local" and fixed:
            warnings.append("error_estimate='local' needs an adaptive integrator; no estimate")
            method_note = "none"
        elif duration == 0:
            est = est_q = est_v = 0.0
        report.update({"error_estimate": est, "error_estimate_q": est_q, "error_estimate_v": est_v,
                       "error_estimate_method": method_note, "error_estimate_wall_time_s": est_wall})

        # -- energy balance: at every sample when q and v were kept, else between the first and last states
        per_sample = "q" in outputs and "v" in outputs
        if not per_sample and cnt:
            q = np.array([q0, run["qf"]])
            v = np.array([v0, run["vf"]])
            w = w[[0, cnt - 1]]
        K = np.empty(len(q))
        U = np.empty(len(q))
        _energies(model.tree, q, v, g, K, U)
        E = K + U
        W = w.sum(axis=1) if cnt else np.zeros(0)
        if cnt:
            scale = max(float(K.max()), float(U.max() - U.min()), float(np.abs(w[-1]).max()), 1e-300)
            resid = np.abs(E - E[0] - W)
            drift, drift_max = float(resid[-1] / scale), float(resid.max() / scale)
        else:
            drift = drift_max = float("nan")
        if not per_sample:
            drift_max = None
        report.update({"energy_drift": drift, "energy_drift_max": drift_max,
                       "work_torque": float(w[-1, 0]) if cnt else 0.0,
                       "work_passive": float(w[-1, 1]) if cnt else 0.0,
                       "energy_initial": float(E[0]) if cnt else float("nan"),
                       "energy_final": float(E[-1]) if cnt else float("nan")})
        report["warnings"] = warnings
        report = {k: (None if isinstance(x, float) and not math.isfinite(x) else x) for k, x in report.items()}
        kept = {"q": run["q"][:cnt], "v": run["v"][:cnt], "tau": run["tau"][:cnt]}
        return Trajectory(t.copy(), kept["q"].copy(), kept["v"].copy(), kept["tau"].copy(), report)
    finally:
        if src.slot >= 0:
            release_callable(src.slot)
