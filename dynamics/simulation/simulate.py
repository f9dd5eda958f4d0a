"""Forward simulation: q(t), v(t) from q0, v0 under joint torques, with an honest report.

``simulate`` is three steps: check the arguments (:class:`Settings`), run the chosen method in the C++ core
(:mod:`.native`: the robot as an ODE with its torque source, passive torques, constraints and contact,
``core/simulation/``), and write the report (:mod:`.report`: status, error estimate, energy balance, constraint
drift, contact).  The whole loop runs in C++ with the GIL released; only a Python-callable torque is called
back, with the GIL taken, once per right-hand-side evaluation.
"""

import math
import time
import weakref
from typing import NamedTuple
from warnings import warn

import numpy as np

from .. import _core
from ..aba import refuse_singular
from ..checks import check_model, real_number, vector
from ..errors import InputError, SimulationWarning
from ..joints import KINDS
from ..task_space import operational_space_inertia
from .. import plot
from ..control.passive import Passive
from ..control.registry import release_callable
from ..control.sources import OPERATIONAL_SPACE
from ..control.validation import make_source
from . import report as R
from ..constrained_dynamics import DEFAULT_BAUMGARTE, baumgarte_gains, project_velocity
from ..constraints import core_constraints, warn_drift, warn_off_manifold
from . import native
from .native import NQUAD, PROJECT_TOL
from .progress import check as check_progress
from .progress import watcher
from .sensitivities import error_estimate as sensitivity_error
from .sensitivities import sensitivity_spec
from .solvers import FIXED, NONFINITE, ORDER, STABILITY_LIMIT, STATS, Options

__all__ = ["simulate", "Trajectory", "INTEGRATORS", "OUTPUTS", "DEFAULT_OUTPUTS"]

INTEGRATORS = ("euler", "implicit_euler", "rk4", "rk45", "radau", "auto", "dop853")
#: what a simulation can keep per sample (besides t); "lambda": the multipliers of a constrained model
OUTPUTS = ("q", "v", "tau", "lambda")
DEFAULT_OUTPUTS = ("q", "v", "tau")


class Trajectory(NamedTuple):
    """t (T,), q (T, nq), v (T, nv), tau (T, nv) applied source torques, report (dict), lam (T, m): the
    constraint multipliers per sample (rows and frames of :mod:`dynamics.constraints`), None unless
    ``outputs`` asked for "lambda"; contacts: the active contacts per sample
    (:class:`dynamics.contact.outputs.ContactSamples`), None unless the contact asked for "contacts"."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    report: dict
    lam: object = None
    contacts: object = None
    sensitivities: object = None

    def plot(self, path=None, *, joint_names=None, show=False):
        """q, v and tau against t with the report's verdict in the title (:func:`dynamics.plot.trajectory`;
        needs matplotlib).  Saves to ``path`` if given; returns the matplotlib Figure."""
        return plot.trajectory(self, path, joint_names=joint_names, show=show)


class Settings(NamedTuple):
    """The checked arguments of one simulate call."""

    integrator: str
    fixed: bool
    q0: np.ndarray
    v0: np.ndarray
    duration: float
    rtol: float
    atol: float
    dt: object  # float or None
    gravity: np.ndarray
    max_steps: int
    outputs: tuple
    error_estimate: str
    out_t: np.ndarray  # sample times
    constrained: bool  # model.constraints non-empty: the KKT right-hand side (.constrained_problem)
    baumgarte: tuple  # (alpha, beta) in 1/s
    project: bool
    contact: object  # None, or the contact resolved for the model (dynamics.contact.resolve.Resolved)
    sens: object = None  # sensitivities.Spec or None
    blowup: float = None  # the joint speed past which the run stops (_blowup of v0)


class RunResult(NamedTuple):
    problem: object  # the RobotProblem, holding the samples
    stats: dict  # the solver's statistics record (solvers.STATS) as Python numbers by field name
    switches: np.ndarray  # the auto switch log (solvers.SWITCH rows)
    wall: float
    qf: np.ndarray  # final state
    vf: np.ndarray
    S: object = None  # sensitivities: per sample (T, 2 nv, ncol) and at the end (2 nv, ncol), or None
    Sf: object = None
    core: object = None  # the core's (Passive, Source) the run used: the error estimate's rerun uses them again


def simulate(model, q0, v0, duration, *, torque=None, integrator="auto", rtol=1e-6, atol=1e-8, dt=None,
             sample_dt=None, gravity=None, max_steps=1_000_000, limits=None, limit_stiffness=1e4,
             limit_damping=100.0, friction_eps=1e-3, error_estimate="rerun", outputs=DEFAULT_OUTPUTS,
             progress=None, baumgarte=None, project=False, contact=None,
             sensitivities=None):
    """Simulate the robot from (q0, v0) for ``duration`` seconds; returns a :class:`Trajectory`.

    torque: None, an (nv,) constant, :class:`dynamics.torques.Table`, :class:`~dynamics.torques.PD`,
        :class:`~dynamics.torques.ComputedTorque`, or a callable f(t, q, v) -> (nv,) (module docs).
    integrator: "euler" | "implicit_euler" | "rk4" (fixed step ``dt``, required) | "rk45" | "dop853" | "radau" |
        "auto" (adaptive, ``rtol`` and ``atol`` on each component of (q, v); ``dt`` if given is the first step).
        ``implicit_euler``: symplectic Euler with the contact, the passive torques and a PD source linearly implicit,
        one solve per step (MuJoCo's step; docs/guide/integrators.md).
    sample_dt: output spacing (the last sample is always t = duration).  Default: every step for fixed-step
        methods, duration/1000 for adaptive ones (dense output between steps).
    gravity: (3,) world gravity, default ``model.gravity``.  max_steps: budget of attempted steps.
    limits: None or "spring" (Hunt-Crossley spring-damper at the URDF position limits, ``limit_stiffness``
        N m/rad, ``limit_damping`` N m s/rad^2).  friction_eps: velocity scale of the regularised Coulomb
        friction.  error_estimate: "rerun" (default), "local" or "none" (:mod:`dynamics.simulation.report`).
    outputs: which of "q", "v", "tau", "lambda" to keep per sample (``t`` always); the others come back as
        empty (0, n) arrays (``lam``: None) and are not computed (the applied torques) or stored.  Without q
        and v per sample the energy balance is taken between the first and last states only
        (``energy_drift_max`` is None).
    progress: None (a bar on a terminal for runs longer than a second), True, False, or a callable
        ``progress(t_reached, duration)`` (:mod:`dynamics.simulation.progress`).
    baumgarte, project: constrained models only (``model.constraints``; ignored otherwise).  The accelerations
        come from the KKT system of :func:`dynamics.constrained_forward_dynamics` with Baumgarte gains
        ``baumgarte=(alpha, beta)`` (1/s; default :data:`dynamics.constrained_dynamics.DEFAULT_BAUMGARTE`, (0, 0): none).
        ``project=True`` projects (q, v) onto phi = 0, Phi_q v = 0 at the start and after every accepted step
        (:mod:`dynamics.simulation.constrained_problem`).  The report adds ``constraint_drift``: the largest
        max|phi| ("position", m or rad) and max|Phi_q v| ("velocity") over the accepted steps and the samples.
    contact: None, or a :class:`dynamics.Contact`: compliant contact with the ground, the world's objects and
        between the model's bodies (:mod:`dynamics.contact`); its generalised force J_c^T f_c joins the
        torques.  The report adds ``contact`` (largest penetration, time in contact, the work of the contact
        forces and the energy they dissipated; :mod:`dynamics.simulation.report`), and ``Trajectory.contacts``
        holds the active contacts per sample when the Contact's ``outputs`` ask for "contacts".
    sensitivities: None, True (dx(t)/dx0) or a sequence of "x0" and the torque source's parameter names (PD:
        "kp", "kd", "q_target", "v_target", "tau_ff"; ComputedTorque: "kp", "kd"; a constant or a Table:
        "tau"): forward sensitivities integrated with the state under the same error control, returned as
        ``Trajectory.sensitivities`` (T, 2 nv, ncol) with the column names and their error estimate in
        ``report["sensitivities"]`` (:mod:`dynamics.simulation.sensitivities`; q-rows and q0-columns are tangent
        vectors, Pinocchio's ``difference`` and ``integrate``, for models with free, spherical or planar joints).

    Raises InputError for bad arguments and when the step budget is exceeded; a run that goes unstable
    stops, returns the samples up to the failure and says so in ``report["status"]`` and ``warnings``.
    """
    warnings = []
    progress = check_progress(progress)
    s = _settings(model, q0, v0, duration, integrator, rtol, atol, dt, sample_dt, gravity, max_steps,
                  error_estimate, outputs, warnings, baumgarte, project, contact)
    ps = _passive(model, s, limits, limit_stiffness, limit_damping, friction_eps)
    src = make_source(model, torque)
    if sensitivities is not None:
        s = s._replace(sens=sensitivity_spec(model, src, sensitivities, s.integrator, s.project))
    try:
        main = _one_run(model, s, ps, src, s.dt, s.out_t, s.rtol, s.atol, max_steps, s.outputs,
                        h0=s.dt if not s.fixed else 0.0, watch=watcher(progress, s.duration), probe=True)
        if main.stats["status"] == NONFINITE and main.stats["steps"] == 0:
            _check_not_singular(model, s.q0, s.v0, s.gravity)
        stability = _stability(s, main.stats["rho0"], warnings)
        if s.contact is not None and s.fixed and s.duration > 0:
            stability = R.contact_stability(model, s, stability, warnings)
        traj = _trajectory(model, s, ps, src, main, stability, warnings)
    finally:
        if src.slot >= 0:
            release_callable(src.slot)
    for message in traj.report["warnings"]:  # also where Python programs look (filters, -W error)
        warn(message, SimulationWarning, stacklevel=2)
    return traj


def _trajectory(model, s, ps, src, main, stability, warnings):
    """The report around the samples of the main run (and the error-estimate rerun)."""
    report = {"integrator": s.integrator, "rtol": None if s.fixed else s.rtol, "atol": None if s.fixed else s.atol,
              "dt": s.dt}
    blowup = s.blowup
    p = main.problem
    cnt = int(p.count[0])
    why = _why_nonfinite(model, s, src, main) if main.stats["status"] == NONFINITE else None
    status, t_final = R.run_status(main.stats, s, blowup, stability, warnings, why)
    report.update(status=status, t_final=t_final, switches=R.switches(main.switches))
    report.update(R.statistics(main.stats, main.wall))
    if stability is not None:
        report["stability"] = stability

    reruns = []

    def rerun(dt, rtol, atol, max_steps):
        reruns.append(_one_run(model, s, ps, src, dt, np.array([0.0]), rtol, atol, max_steps, (), core=main.core))
        return reruns[-1]

    errors = R.error_estimate(model, s, main, rerun, ORDER.get(s.integrator, 0), warnings)
    if s.sens is not None:
        report["sensitivities"] = _sensitivity_report(s, main, reruns, errors)
    R.accuracy_warnings(s, errors, main.qf, main.vf, warnings)
    report.update(errors)
    w = p.out_w[:cnt]
    report.update(R.energy_balance(model, s, p.out_e[:cnt], w))
    lam = None
    if s.constrained:
        report["constraint_drift"] = {"position": float(p.drift[0]), "velocity": float(p.drift[1]),
                                      "baumgarte": list(s.baumgarte), "project": s.project}
        warn_drift(p.drift, warnings)
        if p.project_failures[0]:
            warnings.append(f"project: {int(p.project_failures[0])} position projections did not converge; those "
                            "steps went on from the unprojected configuration (see constraint_drift)")
        lam = p.out_lam[:cnt].copy() if "lambda" in s.outputs else None
    elif "lambda" in s.outputs:
        lam = np.zeros((cnt, 0))
    contacts = None
    if s.contact is not None:
        report["contact"] = R.contact_report(model, s, main, w, warnings)
        from ..contact.outputs import contact_samples
        contacts = contact_samples(s.contact, p.contact, cnt)
    report["warnings"] = warnings
    S = main.S[:cnt].copy() if s.sens is not None else None
    return Trajectory(_rows(p.out_t, cnt), _rows(p.out_q, cnt), _rows(p.out_v, cnt), _rows(p.out_tau, cnt),
                      R.json_safe(report), lam, contacts, S)


def _rows(a, cnt):
    """The first cnt rows of a run's output as an array of its own: the array itself when it has exactly those
    rows (the run made it for this call, nothing else holds it), else a copy of them."""
    return a if a.shape[0] == cnt else a[:cnt].copy()


def _sensitivity_report(s, main, reruns, errors):
    """report["sensitivities"]: the column names and max |S(T) - S_tighter(T)| (the rerun of the estimate)."""
    est = None
    if errors["error_estimate_method"] == "rerun" and reruns and reruns[-1].Sf is not None:
        order = ORDER.get(s.integrator, 0)
        factor = 2 ** order / (2 ** order - 1) if s.fixed else 1.0
        est = sensitivity_error(main.Sf, reruns[-1].Sf, factor)
    elif s.duration == 0:
        est = 0.0
    return {"columns": list(s.sens.columns), "error_estimate": est}


def _why_nonfinite(model, s, src, main):
    """Why a run met a NaN, when the torque source can say: an operational-space task that is singular at the
    last good state (the same verdict and condition number as :func:`dynamics.operational_space_inertia`).
    None otherwise (the report's generic reason stands)."""
    if src.kind != OPERATIONAL_SPACE or src.damping > 0:
        return None
    p = main.problem
    cnt = int(p.count[0])
    q = p.out_q[cnt - 1] if cnt and p.out_q.shape[0] else s.q0
    try:
        operational_space_inertia(model, q, int(src.frame), rows=src.rows)
    except InputError as e:
        return f"the operational-space task is singular: {e}"
    return None


def _one_run(model, s, ps, src, dt, out_t, rtol, atol, max_steps, outputs, h0=0.0, watch=None, probe=False,
             core=None):
    """One run of s.integrator in the C++ core from (q0, v0); samples kept at out_t (``outputs`` of q, v, tau).
    ``core``: the core's (Passive, Source) of ps and src when made already (they are only read by a run)."""
    nv = model.nv
    contact = None
    if s.contact is not None:
        from ..contact.resolve import core_contact
        contact = core_contact(s.contact, model, out_t.shape[0], exact=s.sens is not None)
    nquad = NQUAD + (contact is not None)
    z = np.zeros(2 * nv + nquad)
    z[nv:2 * nv] = s.v0
    ne, sens, out_S, Sf = 2 * nv, None, None, None
    if s.sens is not None:
        ncol = len(s.sens.columns)
        T = out_t.shape[0] if out_t is s.out_t else 0  # (not in the rerun)
        out_S, Sf = np.zeros((T, 2 * nv, ncol)), np.zeros((2 * nv, ncol))
        sens = (bool(s.sens.x0), np.ascontiguousarray(s.sens.params, np.int64).reshape(-1, 3), out_S, Sf)
        z = native.initial_state(model, s.q0, s.v0, s.sens.x0, ncol, nquad)
        ne = 2 * nv * (1 + ncol)
    nsteps = max(1, math.ceil(s.duration / dt * (1 - 1e-12))) if s.fixed and s.duration > 0 else 0
    opt = Options(nc=nv, nvel=nv, ne=ne, max_steps=int(max_steps), nsteps=nsteps, dt=float(dt or 0.0),
                  rtol=float(rtol), atol=float(atol), h0=float(h0 or 0.0), hmax=np.inf, blowup=s.blowup,
                  probe=int(probe and s.integrator in STABILITY_LIMIT and s.duration > 0))
    if core is None:
        core = (native.core_passive(model, ps), native.core_source(model, src))
    tic = time.perf_counter()
    p, st, sw = native.run(s.integrator, model, core[0], core[1], s.q0, z, s.duration, out_t, outputs, opt,
                           watch=watch, sens=sens, baumgarte=s.baumgarte if s.constrained else None,
                           project=s.project, contact=contact)
    wall = time.perf_counter() - tic
    qf = np.empty(model.nq)
    _core.retract(model.core, p.base, z[:nv], qf)
    # (the report reads a dozen fields: Python numbers once, not a numpy scalar per read)
    return RunResult(p, dict(zip(STATS.names, st.item())), sw, wall, qf, z[nv:2 * nv].copy(), out_S, Sf, core)


def _blowup(v0):
    """The joint speed past which a run stops (status "blowup"); v0: (nv,), or (n, nv) for several states."""
    # (v0 is checked finite: Python's max is numpy's, exactly, and without its call's cost)
    values = v0.tolist() if type(v0) is np.ndarray and v0.ndim == 1 else np.ravel(v0).tolist()
    return max(1e6, 1e4 * max(map(abs, values), default=0.0))


def _stability(s, rho, warnings):
    """Fixed-step methods: dt * spectral radius of the Jacobian at t0 against the method's stability limit
    (rho is measured by the run itself, before its first step)."""
    if not s.fixed or s.duration <= 0 or not rho >= 0:
        return None
    rho = float(rho)
    limit = STABILITY_LIMIT.get(s.integrator)
    if limit is None:  # implicit_euler: no limit on the stiff forces it treats implicitly
        return None
    if s.dt * rho > limit:
        warnings.insert(0, f"dt={s.dt:g} exceeds the stability limit of {s.integrator} for this problem at t=0 "
                        f"(dt * spectral radius = {s.dt * rho:.3g} > {limit}): expect blow-up; use "
                        f"dt < {limit / rho:.3g} or integrator='radau'")
    return {"dt_times_spectral_radius": s.dt * rho, "limit": limit, "spectral_radius": rho}


# ---------------------------------------------------------------------------------------------------
# checks
#: the Baumgarte gains of ``baumgarte=None``, checked once
_DEFAULT_GAINS = baumgarte_gains(DEFAULT_BAUMGARTE)
_OUTPUT_SET = frozenset(OUTPUTS)


class _Facts(NamedTuple):
    """What simulate reads of a model on every call and that never changes (models are immutable)."""

    units: tuple  # per unit block of q (a quaternion, a planar joint's (cos, sin)): (start, size, what, joint name)
    qpos: np.ndarray  # (nv,) int64, read-only: _qpos_map
    passive: tuple  # damping, friction, lower, upper: the model's (nv,) arrays as C-contiguous float64
    gravity: np.ndarray  # (3,) the model's gravity, checked, read-only (gravity=None's)


#: per model, its _Facts (kept while the model lives)
_FACTS = weakref.WeakKeyDictionary()


def _facts(model):
    facts = _FACTS.get(model)
    if facts is None:
        tree, units = model.tree, []
        for i, code in enumerate(tree.jtype):
            kind = KINDS[int(code)]
            if kind.unit:
                n = kind.unit[1]
                units.append((int(tree.q_idx[i]) + kind.unit[0], n,
                              "quaternion (x, y, z, w)" if n == 4 else "(cos theta, sin theta)", model.joint_names[i]))
        qpos = _qpos_map(model)
        qpos.flags.writeable = False
        # (a model's arrays are read-only, contiguous float64 already: these are the model's own arrays)
        passive = tuple(np.ascontiguousarray(a, float) for a in (model.damping, model.friction, model.lower, model.upper))
        gravity = vector("gravity", model.gravity, 3)
        gravity.flags.writeable = False
        facts = _FACTS[model] = _Facts(tuple(units), qpos, passive, gravity)
    return facts


def _settings(model, q0, v0, duration, integrator, rtol, atol, dt, sample_dt, gravity, max_steps,
              error_estimate, outputs, warnings, baumgarte, project, contact=None):
    """Check every argument once, with an error that names it; returns :class:`Settings`."""
    check_model(model)
    if integrator not in INTEGRATORS:
        raise InputError(f"integrator: expected one of {INTEGRATORS}, got {integrator!r}")
    _not_a_batch(model, q0, v0)
    q0 = _check_q(model, q0, warnings)
    v0 = vector("v0", v0, model.nv)
    duration = real_number("duration", duration, lo=0.0)
    rtol = real_number("rtol", rtol, lo=1e-14, hi=1.0)
    atol = real_number("atol", atol, lo=0.0)
    fixed = integrator in FIXED
    dt = real_number("dt", dt, lo=0.0, lo_open=True, allow_none=True)
    if fixed and dt is None:
        raise InputError(f"dt: required (> 0) for the fixed-step integrator {integrator!r}")
    sample_dt = real_number("sample_dt", sample_dt, lo=0.0, lo_open=True, allow_none=True)
    g = _facts(model).gravity if gravity is None else vector("gravity", gravity, 3)
    if isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or max_steps < 1:
        raise InputError(f"max_steps: expected a positive int, got {max_steps!r}")
    if outputs is not DEFAULT_OUTPUTS and (isinstance(outputs, str) or not set(outputs) <= _OUTPUT_SET):
        raise InputError(f"outputs: expected a subset of {OUTPUTS}, got {outputs!r}")
    if error_estimate not in ("rerun", "local", "none"):
        raise InputError(f"error_estimate: expected 'rerun', 'local' or 'none', got {error_estimate!r}")
    if fixed:
        nsteps = math.ceil(duration / dt * (1 - 1e-12)) if duration > 0 else 0
        if nsteps > max_steps:
            raise InputError(f"max_steps: dt={dt:g} needs {nsteps} steps over {duration:g} s, more than "
                             f"max_steps={max_steps}")
    constrained = bool(getattr(model, "constraints", ()))
    gains = _DEFAULT_GAINS if baumgarte is None else baumgarte_gains(baumgarte)
    if not isinstance(project, (bool, np.bool_)):
        raise InputError(f"project: expected True or False, got {project!r}")
    if constrained and project:
        q0, v0 = _project_initial(model, q0, v0, warnings)
    elif constrained:
        warn_off_manifold(model, q0, warnings)
    resolved = None
    if contact is not None:
        from ..contact.resolve import resolve
        resolved = resolve(contact, model, g)
    kept = DEFAULT_OUTPUTS if outputs is DEFAULT_OUTPUTS else tuple(o for o in OUTPUTS if o in outputs)
    return Settings(integrator, fixed, q0, v0, duration, rtol, atol, dt, g, int(max_steps), kept, error_estimate,
                    _sample_times(duration, dt, sample_dt, fixed), constrained, gains, bool(project), resolved,
                    blowup=_blowup(v0))


def _project_initial(model, q0, v0, warnings):
    """project=True: start on the constraint manifold (the steps then stay on it); say how far (q0, v0) moved."""
    q = np.empty(model.nq)
    err = _core.project_position(model.core, core_constraints(model), q0, PROJECT_TOL, 50, q)
    if not err <= PROJECT_TOL:
        raise InputError(f"q0: the constraints cannot be closed near q0 (max |phi| = {err:.3g} after projection); "
                         "start from dynamics.assemble(model, q0)")
    v = project_velocity(model, q, v0)
    moved = max(float(np.max(np.abs(q - q0), initial=0.0)), float(np.max(np.abs(v - v0), initial=0.0)))
    if moved > 1e-9:
        warnings.append(f"project: (q0, v0) moved onto the constraints by up to {moved:.3g}")
    return q, v


def _check_not_singular(model, q0, v0, g):
    """A singular M at q0: say which joint and why (:func:`dynamics.checks.singular_joint_error`, the rule
    ``dynamics check`` applies too), rather than a run that stops with NaN at t0; through the run's own ABA
    (the core's ABA).  Asked only after a run that could not take its first step (the right-hand side was not
    finite at t0)."""
    refuse_singular(model, q0, "q0")


#: Passive.f_ext: no external forces (read-only, shared)
_NO_FORCES = np.zeros((0, 6))
_NO_FORCES.flags.writeable = False


def _passive(model, s, limits, limit_stiffness, limit_damping, friction_eps):
    if limits not in (None, "spring"):
        raise InputError(f"limits: expected None or 'spring', got {limits!r}")
    limit_stiffness = real_number("limit_stiffness", limit_stiffness, lo=0.0)
    limit_damping = real_number("limit_damping", limit_damping, lo=0.0)
    friction_eps = real_number("friction_eps", friction_eps, lo=0.0, lo_open=True)
    facts = _facts(model)
    damping, friction, lower, upper = facts.passive
    return Passive(damping, friction, friction_eps, 1 if limits == "spring" else 0, lower, upper, facts.qpos,
                   limit_stiffness, limit_damping, s.gravity, _NO_FORCES)


def _not_a_batch(model, q0, v0):
    """A batch of initial states (B, nq) is a mistake here: say so and point to simulate_many."""
    if type(q0) is np.ndarray and q0.ndim == 1 and type(v0) is np.ndarray and v0.ndim == 1:
        return  # (the usual call)
    for name, x, n in (("q0", q0, model.nq), ("v0", v0, model.nv)):
        shape = np.shape(x) if isinstance(x, (np.ndarray, list, tuple)) else ()
        if len(shape) == 2 and shape[1] == n:
            raise InputError(f"{name}: expected shape ({n},), got {shape}: one run per call; for a batch of "
                             f"{shape[0]} runs use dynamics.simulate_many(model, q0, v0, duration, ...)")


def _check_q(model, q0, warnings):
    """q0 checked, its unit blocks (quaternions, a planar joint's (cos, sin)) normalised with a warning."""
    q = vector("q0", q0, model.nq)
    for k, n, what, joint in _facts(model).units:
        nrm = float(np.linalg.norm(q[k:k + n]))
        if nrm < 1e-6:
            raise InputError(f"q0: the {what} q0[{k}:{k + n}] of joint {joint!r} is zero")
        if abs(nrm - 1.0) > 1e-6:
            warnings.append(f"q0: {what} of joint {joint!r} had norm {nrm:.6g}; normalised")
        q[k:k + n] /= nrm
    return q


def _qpos_map(model):
    """Per velocity coordinate: the q index of a joint with position limits (1-dof), -1 for the others."""
    qpos = np.full(model.nv, -1, np.int64)
    tree = model.tree
    for i, code in enumerate(tree.jtype):
        if KINDS[int(code)].limited:
            qpos[tree.v_idx[i]] = tree.q_idx[i]
    return qpos


def _sample_times(duration, dt, sample_dt, fixed):
    if sample_dt is None:
        if fixed:
            n = max(1, math.ceil(duration / dt * (1 - 1e-12))) if duration > 0 else 0
            if n <= 16:  # (a few steps: the same products k dt, without numpy's calls)
                return np.array([min(k * dt, duration) for k in range(n)] + [duration])
            t = np.minimum(np.arange(n + 1) * dt, duration)
            t[-1] = duration
            return t
        sample_dt = duration / 1000 if duration > 0 else 1.0
    if duration <= 0:
        return np.zeros(1)
    n = math.floor(duration / sample_dt * (1 + 1e-12))
    t = np.arange(n + 1) * sample_dt
    k = int(np.searchsorted(t, duration * (1 - 1e-12)))  # the first k times are < duration (less round-off)
    if k > n:  # (all of them: the end is one more sample)
        return np.append(t, duration)
    t[k] = duration  # (usually k = n: the last multiple is the end, within round-off)
    return t if k == n else t[:k + 1].copy()
