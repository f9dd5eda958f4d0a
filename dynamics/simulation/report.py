"""The report of a simulation (``Trajectory.report``, a JSON-serialisable dict): status, switches, the error
estimate of the final state and the energy balance.

Fields: ``integrator`` (the method asked for), ``switches`` (for ``auto``: each switch's time, from, to and
reason), ``status`` ("ok", or why the run stopped early: "unstable: ..."), ``t_final``, ``steps`` (accepted),
``rejected_steps``, ``rhs_evals`` (ABA calls, Jacobian columns included), ``jacobian_evals``,
``lu_decompositions``, ``wall_time_s`` (the integration run alone), the error fields below, ``energy_drift``,
``energy_drift_max``, ``work_torque``, ``work_passive``, ``energy_initial``, ``energy_final``, ``stability``
(fixed-step methods: dt * spectral radius of the Jacobian at t0, and the method's stability limit),
``constraint_drift`` (constrained models: the largest max |phi| and max |Phi_q v| over the accepted steps and
the samples, the Baumgarte gains, whether steps were projected; :mod:`.constrained_problem`), ``warnings``.
Non-finite numbers are reported as None (strict JSON); the warnings say why.

How ``error_estimate`` is computed
----------------------------------
``error_estimate`` estimates the *global* error of the returned final state, as the max-norm over
``difference(q_true, q_final)`` (rad or m per velocity coordinate; :func:`dynamics.difference`)
and ``v_final - v_true`` (rad/s or m/s).  ``error_estimate_q`` and ``error_estimate_v`` are the two parts.
It is measured, not modelled, by a second run of the same method on the same problem (``error_estimate=
"rerun"``, the default):

* adaptive methods (``rk45``, ``dop853``, ``radau``, ``auto``): a second run with rtol and atol divided by 32.
  With tolerance proportionality (global error ~ C tol^a, a in [0.8, 1] for these methods) the tighter run's
  error is 16-32x smaller, so ``|y(tol) - y(tol/32)|`` is the error of y(tol) to within ~6%.
* fixed-step methods (``euler``, ``implicit_euler``, ``rk4``, order p = 1, 1, 4): a second run with dt/2, and Richardson's estimate
  ``|y(dt) - y(dt/2)| * 2^p / (2^p - 1)``.

The second run costs 1-3x the first (Panda under PD, 1 s, auto: ~2x) and is timed separately
(``error_estimate_wall_time_s``; ``cost_of_estimate`` is its ratio to the run's ``wall_time_s``).  With
``error_estimate="local"`` the report gives instead the sum over accepted steps of the max-norm of the local
error estimates (adaptive methods only): cheap, but it can understate the global error of unstable or chaotic
dynamics, whose local errors grow.  ``"none"`` skips it (``error_estimate`` is None).

When the estimate is of order one (q part >= 0.1 rad or m, or v part >= 0.1 max(1, the largest final |v|))
or, for adaptive methods, more than 1000 times the asked tolerance (atol + rtol max(1, |q|, |v|)), the
report's ``warnings`` say so: the status stays "ok" (the run did finish), but the numbers are not accurate.

Energy balance
--------------
``energy_drift = |E(T) - E(0) - W_source(T) - W_passive(T)| / scale``, E = kinetic + potential energy, with

    scale = max(max_t K, max_t U - min_t U, |W_source(T)|, |W_passive(T)|, m L max(|g|, 1 m/s^2))

over the samples: every term is independent of the potential's arbitrary zero, and the last one, the
robot's own energy scale (total mass m, size L = the sum of its joint offsets plus its largest centre-of-mass
offset), keeps a robot that hardly moves (held still by PD and gravity compensation: K, the range of U and
the work all ~0) from dividing rounding noise by ~0.  ``energy_drift_max`` is the largest balance residual
over all samples, on the same scale (samples between steps come from dense output and are less accurate
than step points).  The scale used is reported as ``energy_scale`` (J).
"""

import math
import weakref

import numpy as np

from .. import _core
from ..errors import InputError
from .solvers import OK, RADAU, STATUS_NAMES, SWITCH_CONTACT, SWITCH_STIFF

WHY = {"nonfinite": "a NaN/inf appeared in the state or its derivative",
       "blowup": "a joint velocity exceeded {blowup:.3g}",
       "step_too_small": "the step size collapsed below the time resolution"}


def run_status(st, s, blowup, stability, warnings, why=None):
    """The report's status for the run's statistics; raises InputError when the step budget ran out.  ``why``:
    a more precise reason for a stopped run than the statistics give (a singular task)."""
    status = STATUS_NAMES[st["status"]]
    t_final = float(st["t"]) if s.duration > 0 else 0.0
    if status == "max_steps":
        raise InputError(f"max_steps: step budget of {s.max_steps} exhausted at t={t_final:.6g} s of "
                         f"{s.duration:g} s; raise max_steps, loosen rtol/atol, or use integrator='radau' if "
                         "the problem is stiff")
    if status != "ok":
        status = f"unstable: {why or WHY[status].format(blowup=blowup)} at t={t_final:.6g} s"
        warnings.append(f"simulation stopped early, {status}; the trajectory ends at the last good sample")
        if s.fixed and stability and stability["dt_times_spectral_radius"] <= stability["limit"]:
            warnings.append(f"{s.integrator}: consider a smaller dt or integrator='radau'")
    if s.integrator == "rk45" and st["stiff_t"] >= 0:
        warnings.append(f"rk45: the problem looks stiff from t={st['stiff_t']:.6g} s (h*|lambda| > 3.25 on "
                        "15 accepted steps, DOPRI5's test); integrator='radau' or 'auto' will be cheaper")
    return status, t_final


def switches(log):
    """The auto switch log as a list of dicts (time, from, to, reason)."""
    if not len(log):  # (the usual run: no switch, and no iteration over an empty record array)
        return []
    out = []
    for rec in log:
        to = "radau" if rec["to"] == RADAU else "rk45"
        if rec["reason"] == SWITCH_STIFF:
            reason = f"stiffness detected: h*|lambda| = {rec['value']:.3g} > 3.25 on 15 accepted rk45 steps"
        elif rec["reason"] == SWITCH_CONTACT:
            reason = "contact: the state touches something (compliant contact and regularised friction are stiff)"
        else:
            reason = f"no longer stiff: h*rho(J) = {rec['value']:.3g} < 2 on 20 accepted radau steps"
        out.append({"t": float(rec["t"]), "from": "radau" if to == "rk45" else "rk45", "to": to, "reason": reason})
    return out


def statistics(st, wall):
    return {"steps": int(st["steps"]), "rejected_steps": int(st["rejected"]), "rhs_evals": int(st["rhs_evals"]),
            "jacobian_evals": int(st["jacobian_evals"]), "lu_decompositions": int(st["lu_decompositions"]),
            "wall_time_s": wall}


def error_estimate(model, s, run, rerun, order, warnings):
    """The error fields of the report.  ``rerun(dt, rtol, atol, max_steps)`` runs the same problem again and
    returns its result (or None when the budget forbids it)."""
    est = est_q = est_v = None
    wall = 0.0
    method = s.error_estimate
    ok = run.stats["status"] == OK
    if method == "rerun" and ok and s.duration > 0:
        if s.fixed and 2 * math.ceil(s.duration / s.dt) > s.max_steps:
            warnings.append("error_estimate: the dt/2 rerun would exceed max_steps; no estimate")
            method = "none"
        else:
            if s.fixed:
                r2 = rerun(s.dt / 2, s.rtol, s.atol, s.max_steps)
                factor = 2 ** order / (2 ** order - 1)
            else:
                r2 = rerun(None, max(s.rtol / 32, 1e-14), s.atol / 32, 4 * s.max_steps)
                factor = 1.0
            wall = r2.wall
            if r2.stats["status"] != OK:
                est = est_q = est_v = float("inf")
                warnings.append(f"error_estimate: the tighter rerun failed ({STATUS_NAMES[r2.stats['status']]}); "
                                "estimate set to inf")
            else:
                eq, ev = _core.state_error(model.core, run.qf, run.vf, r2.qf, r2.vf)  # (state_error's numbers)
                est_q, est_v = eq * factor, ev * factor
                est = max(est_q, est_v)
    elif method == "local" and not s.fixed:
        est = float(run.stats["local_error"])
    elif method == "local":
        warnings.append("error_estimate='local' needs an adaptive integrator; no estimate")
        method = "none"
    elif s.duration == 0:
        est = est_q = est_v = 0.0
    return {"error_estimate": est, "error_estimate_q": est_q, "error_estimate_v": est_v,
            "error_estimate_method": method, "error_estimate_wall_time_s": wall,
            "cost_of_estimate": wall / run.wall if run.wall > 0 else 0.0}


def energy_balance(model, s, e, w):
    """The energy fields of the report from the samples' energies e (cnt, 2) (kinetic, potential; the run's
    ``emit`` wrote them) and work w: at every sample when q and v were kept, else between the first and last
    samples (then ``energy_drift_max`` is None)."""
    cnt = len(e)
    per_sample = "q" in s.outputs and "v" in s.outputs
    if not per_sample and cnt:
        e, w = e[[0, cnt - 1]], w[[0, cnt - 1]]
    if not cnt:
        nan = float("nan")
        return {"energy_drift": nan, "energy_drift_max": nan if per_sample else None, "energy_scale": nan,
                "work_torque": 0.0, "work_passive": 0.0, "energy_initial": nan, "energy_final": nan}
    # (numpy's operations in numpy's order, in one pass in the core: 0.3 us for a few samples or a thousand)
    k_max, u_range, w_max, resid_last, resid_max, e_first, e_last = _core.energy_balance_terms(e, w)
    scale = max(k_max, u_range, w_max, robot_energy_scale(model, s.gravity))
    drift, drift_max = float(resid_last / scale), float(resid_max / scale)
    return {"energy_drift": drift, "energy_drift_max": drift_max if per_sample else None, "energy_scale": scale,
            "work_torque": float(w[-1, 0]), "work_passive": float(w[-1, 1]),
            "energy_initial": e_first, "energy_final": e_last}


#: per model: its total mass and size (robot_energy_scale), and the scales of the gravities asked for
_ENERGY = weakref.WeakKeyDictionary()


def robot_energy_scale(model, gravity):
    """m L max(|g|, 1 m/s^2) (J): total mass, size = sum of joint offsets + the largest centre-of-mass offset."""
    facts = _ENERGY.get(model)
    if facts is None:
        tree = model.tree
        mass = float(np.sum(tree.mass))
        com = np.linalg.norm(tree.h, axis=1) / np.maximum(tree.mass, 1e-300) if len(tree.mass) else np.zeros(1)
        size = float(np.sum(np.linalg.norm(tree.Xpos, axis=1))) + float(np.max(com, initial=0.0))
        facts = _ENERGY[model] = (mass, size, {})
    mass, size, scales = facts
    key = np.asarray(gravity, float).tobytes()
    scale = scales.get(key)
    if scale is None:
        scale = max(mass * size * max(float(np.linalg.norm(gravity)), 1.0), 1e-300)
        if len(scales) < 16:
            scales[key] = scale
    return scale


def accuracy_warnings(s, fields, qf, vf, warnings):
    """Warn when the error estimate says the final state is not accurate (module docs)."""
    est, est_q, est_v = fields["error_estimate"], fields.get("error_estimate_q"), fields.get("error_estimate_v")
    if est is None or not math.isfinite(est):
        return
    vsize = max(1.0, _abs_max(vf))
    size = max(vsize, _abs_max(qf))  # the magnitude rtol is relative to
    if est_q is not None and est_v is not None:
        order_one = est_q >= 0.1 or est_v >= 0.1 * vsize  # q: rad or m, absolute (angles wrap)
    else:
        order_one = est >= 0.1 * vsize
    what = "the fixed step dt" if s.fixed else "the tolerance"
    tol = s.atol + s.rtol * size if not s.fixed else None
    if order_one:
        warnings.append(f"error_estimate = {est:.3g} is of order one (q error {_g(est_q)} rad or m, v error "
                        f"{_g(est_v)} at speeds up to {vsize:.3g}): the final state is not accurate; reduce {what}"
                        + ("" if s.fixed else " or use integrator='radau' if the problem is stiff"))
    elif tol is not None and est > 1000 * tol:
        warnings.append(f"error_estimate = {est:.3g} is {est / tol:.3g} times the asked tolerance (atol + rtol |y| = "
                        f"{tol:.3g}): the dynamics amplify errors (chaotic or near-unstable motion, impacts); "
                        "tighten rtol/atol to get the accuracy asked")


def _abs_max(x):
    """float(np.max(np.abs(x), initial=0.0)) of a float vector: in Python floats when every value is finite (the
    same number, without numpy's calls), numpy's way otherwise (its NaN rule)."""
    values = x.tolist()
    if math.isfinite(sum(values)):
        return max(map(abs, values), default=0.0)
    return float(np.max(np.abs(x), initial=0.0))


def _g(x):
    return "n/a" if x is None else f"{x:.3g}"


def json_safe(report):
    """Non-finite floats become None (strict JSON)."""
    floats = [x for x in report.values() if isinstance(x, float)]
    if math.isfinite(sum(floats)):  # (every float finite: the report as it is, no second dict)
        return report
    return {k: (None if isinstance(x, float) and not math.isfinite(x) else x) for k, x in report.items()}


def state_error(model, q1, v1, q2, v2):
    """(max |q1 - q2| on the manifold, max |v1 - v2|) between two states, or the largest over two batches of
    states (rows; the error estimate's, and tests' and benchmarks'): the core's configuration difference."""
    q1, q2 = np.ascontiguousarray(q1, float), np.ascontiguousarray(q2, float)
    if q1.ndim == 2 and model.nq != model.nv:
        errs = [state_error(model, a, va, b, vb) for a, va, b, vb in zip(q1, np.atleast_2d(v1), q2, np.atleast_2d(v2))]
        return max(e[0] for e in errs), max(e[1] for e in errs)
    if model.nq == model.nv:  # 1-dof joints only: the difference is q1 - q2
        d = q1 - q2
    else:
        d = np.empty(model.nv)
        _core.difference(model.core, q2, q1, d)
    dv = np.asarray(v1, float) - np.asarray(v2, float)
    return float(np.max(np.abs(d), initial=0.0)), float(np.max(np.abs(dv), initial=0.0))


# ---------------------------------------------------------------------------------------------------------
# contact (simulate(..., contact=...))
def contact_report(model, s, run, w, warnings):
    """The report's ``contact`` fields: the largest penetration over the accepted steps (m), the time in contact
    (s: the accepted steps that end with a contact), the work of the contact forces W_c (J: what they gave the
    robot), the elastic energy E_el = 1/2 k x^2 the contacts hold at the start and the end, and the energy the
    contacts dissipated (damping and friction): -W_c - (E_el(T) - E_el(0)) >= 0."""
    from ..contact.evaluation import elastic_energy_at
    c = run.problem.contact  # (a CoreContact: what the run's contact wrote)
    work = float(w[-1, 2]) if len(w) and w.shape[1] > 2 else 0.0
    e0 = elastic_energy_at(model, s.contact, s.q0, s.v0)
    e1 = elastic_energy_at(model, s.contact, run.qf, run.vf)
    out = {"max_penetration": float(c.track[0]), "time_in_contact": float(c.track[1]), "work_contact": work,
           "elastic_energy_initial": e0, "elastic_energy_final": e1, "energy_dissipated": -work - (e1 - e0),
           "pairs": int(s.contact.scene.pair_a.shape[0]), "max_contacts": int(s.contact.scene.max_contacts)}
    defaults = [m for m in (s.contact.contact.friction, *s.contact.contact.materials.values()) if m.stiffness is None]
    allowance = min((m.penetration_allowance for m in defaults), default=None)
    if allowance is not None and out["max_penetration"] > 10 * allowance:
        warnings.append(f"contact: the largest penetration {out['max_penetration']:.3g} m is more than 10x the "
                        f"penetration allowance ({allowance:g} m) the default stiffness was made for: lower the "
                        "allowance, give a stiffness, or check the geometry")
    if s.integrator == "auto" and any(x["to"] == "radau" for x in switches(run.switches)):
        out["stiff"] = "auto switched to radau where contact made the problem stiff (see switches)"
    return out


def contact_spectral_radius(model, resolved):
    """An estimate of the largest |eigenvalue| contact adds to the right-hand side (1/s), for the fixed-step
    stability warning: per pair, the normal spring-damper (stiffness k, the damping k x d at the static sinking
    x = m g / k, m = the mass of the moving body's whole tree) and the friction's viscous slope 2 mu_s f_n / v_s
    at f_n = m g (rate 2 mu_s g / v_s)."""
    from ..contact.forces import K_DISS, K_MU_S, K_STIFF, K_VS
    tree = model.tree
    g = max(float(np.linalg.norm(model.gravity)), 1.0)
    root = np.arange(len(tree.parents))
    for i in range(len(tree.parents)):
        if tree.parents[i] >= 0:
            root[i] = root[tree.parents[i]]
    tree_mass = {r: float(np.sum(tree.mass[root == r])) for r in set(root.tolist())}
    rho = 0.0
    for j, (a, b) in enumerate(resolved.pair_body):
        body = a if a >= 0 else b
        if body < 0:
            continue
        m = max(tree_mass[int(root[body])], 1e-12)
        k, d, mu, vs = (resolved.mat[j, c] for c in (K_STIFF, K_DISS, K_MU_S, K_VS))
        omega, damp = math.sqrt(k / m), 0.5 * d * g
        rho = max(rho, damp + math.sqrt(damp * damp + omega * omega), 2 * mu * g / vs)
    return rho


def contact_stability(model, s, stability, warnings):
    """Fixed-step methods with contact: dt against the stiffness contact adds (:func:`contact_spectral_radius`),
    which the probe at t0 misses when nothing touches yet; a warning when dt * rho exceeds the method's limit."""
    from .solvers import STABILITY_LIMIT
    limit = STABILITY_LIMIT.get(s.integrator)
    if limit is None:  # implicit_euler: the contact's stiffness is in its implicit part
        return stability
    rho = contact_spectral_radius(model, s.contact)
    stability = dict(stability or {}, contact_spectral_radius=rho, dt_times_contact_spectral_radius=s.dt * rho,
                     limit=limit)
    if s.dt * rho > limit:
        warnings.insert(0, f"dt={s.dt:g} is too large for the contact's stiffness: dt * (estimated contact "
                        f"spectral radius {rho:.3g} 1/s) = {s.dt * rho:.3g} > {limit} ({s.integrator}'s stability "
                        f"limit); expect blow-up or chatter in contact: use dt < {limit / rho:.3g}, a softer "
                        "Material (penetration_allowance, stiction_velocity), or integrator='radau'/'auto'")
    return stability
