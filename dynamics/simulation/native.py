"""One run of the simulation in the C++ core (``core/simulation/``): the passive torques, the torque source and the
samples as the core reads and writes them; a constrained model's run is the core's ConstrainedProblem
(``core/simulation/constrained_problem.hpp``), a run with contact takes the core's ContactModel
(``core/contact/contact_model.hpp``)."""

import weakref
from typing import NamedTuple

import numpy as np

from .. import _core
from ..constraints import core_constraints
from ..control.registry import _REGISTRY
from ..errors import DeadlineExceeded, InputError
from ..parallel import seconds_left
from . import solvers


#: the quadratures of a run's state: W_source, W_passive (a run with contact has a third, W_contact)
NQUAD = 2
#: a constrained run's position projection stops below this max |phi| (core/simulation/constrained_problem.hpp)
PROJECT_TOL = 1e-12


class Samples(NamedTuple):
    """What a run wrote per sample (the report and the Trajectory read these)."""

    out_t: np.ndarray
    out_q: np.ndarray
    out_v: np.ndarray
    out_tau: np.ndarray
    out_w: np.ndarray
    out_e: np.ndarray
    count: np.ndarray
    base: np.ndarray
    #: a constrained model's: multipliers per sample (T or 0, m), the largest (max |phi|, max |Phi_q v|) seen, and
    #: the number of position projections that failed
    out_lam: np.ndarray = None
    drift: np.ndarray = None
    project_failures: np.ndarray = None
    #: a run with contact: its :class:`dynamics.contact.resolve.CoreContact` (the tracking, the kept contacts)
    contact: object = None


#: per model, the core's Passive made of the model's own (read-only) arrays, by the run's parameters: {(friction_eps,
#: limits, k_limit, b_limit, gravity bytes): (qpos, core Passive)}; the core only reads it, from any thread
_PASSIVE = weakref.WeakKeyDictionary()


def core_passive(model, ps):
    """The core's passive torques for :class:`dynamics.control.passive.Passive`."""
    own = (ps.damping is model.damping and ps.friction is model.friction and ps.lower is model.lower
           and ps.upper is model.upper and not ps.qpos.flags.writeable)  # (then nothing can change them)
    if own:
        cache = _PASSIVE.get(model)
        if cache is None:
            cache = _PASSIVE[model] = {}
        key = (float(ps.friction_eps), ps.limits, float(ps.k_limit), float(ps.b_limit),
               np.asarray(ps.gravity, float).tobytes())
        hit = cache.get(key)
        if hit is not None and hit[0] is ps.qpos:
            return hit[1]
    core = _core.Passive(model.core, ps.damping, ps.friction, float(ps.friction_eps), ps.limits == 1, ps.lower,
                         ps.upper, ps.qpos, float(ps.k_limit), float(ps.b_limit), ps.gravity)
    if own:
        if len(cache) >= 16:  # (a few gravities and limit settings per model at most, in practice)
            cache.clear()
        cache[key] = (ps.qpos, core)
    return core


def _torque_check(nv):
    def check(tau):
        tau = np.asarray(tau, dtype=np.float64)
        if tau.shape != (nv,):
            raise InputError(f"torque: the callable must return shape ({nv},), got {tau.shape}")
        return np.ascontiguousarray(tau)
    return check


def core_source(model, src):
    """The core's torque source for :class:`dynamics.control.sources.Source`."""
    fn = _REGISTRY[src.slot][0] if src.slot >= 0 else None
    orientation = np.asarray(src.orientation, float).reshape(-1, 12)
    if orientation.shape[0] != src.times.shape[0]:
        orientation = np.zeros((src.times.shape[0], 12))
    return _core.Source(model.core, int(src.kind), src.times, np.asarray(src.table, float), src.gains, src.qref,
                        int(src.frame), np.asarray(src.rows, np.int64), np.asarray(src.task_gains, float),
                        orientation, float(src.damping), fn, None if fn is None else _torque_check(model.nv))


def chart_matrix(model, q, delta):
    """C = d delta / d e (nv, nv) for the tangent displacement e at q = retract(base, delta): column k is the chart
    rate of e_k (:mod:`.sensitivities`)."""
    nv = model.nv
    C, e, col = np.empty((nv, nv)), np.zeros(nv), np.empty(nv)
    for k in range(nv):
        e[k] = 1.0
        _core.chart_rate(model.core, q, delta, e, col)
        e[k] = 0.0
        C[:, k] = col
    return C


def initial_state(model, q0, v0, x0, ncol, nquad=2):
    """z0 of a run with sensitivities: [0, v0, S0 column by column, 0 (nquad quadratures)], S0 = [C(q0, 0) | 0] on the q0 columns'
    q-rows (the identity for 1-dof joints) and the identity on the v0 columns."""
    nv = model.nv
    n2, nx = 2 * nv, 2 * nv if x0 else 0
    z = np.zeros(n2 + n2 * ncol + nquad)
    z[nv:n2] = v0
    S0 = np.zeros((n2, ncol))
    S0[:, :nx] = np.eye(n2)[:, :nx]
    if nx and model.nq != nv:
        S0[:nv, :nv] = chart_matrix(model, q0, np.zeros(nv))
    z[n2:n2 + n2 * ncol] = S0.T.ravel()
    return z


#: a fresh run's statistics record as bytes: a run's record is a new array over a copy of them (numpy copies a
#: record array field by field, 4 us; a bytearray, then a view, 0.6 us)
_STATS0 = solvers.new_stats().tobytes()


def run(method, model, passive, source, q0, z, t_end, out_t, outputs, opt, watch=None, t0=0.0, sens=None,
        baumgarte=None, project=False, contact=None):
    """Run ``method`` from (t0, z) to t_end (z advanced in place), samples at out_t keeping ``outputs``; returns
    (Samples, stats record, switch log's used rows).  ``sens``: None, or (x0, params (P, 3), out_S, Sf) for a run
    with sensitivities (:mod:`.sensitivities`), S written into out_S per sample and Sf at the end.  ``baumgarte``:
    None, or the gains (alpha, beta) of a constrained model's run (its multipliers kept when ``outputs`` has
    "lambda"), ``project`` whether its steps are projected onto the constraints.  ``contact``: None, or the run's
    :class:`dynamics.contact.resolve.CoreContact`."""
    nv, nq, T = model.nv, model.nq, out_t.shape[0]
    # (uninitialised: the core writes every column of a sample's rows, and only the count rows written are read)
    out_q, out_v = np.empty((T if "q" in outputs else 0, nq)), np.empty((T if "v" in outputs else 0, nv))
    out_tau, out_w = np.empty((T if "tau" in outputs else 0, nv)), np.empty((T, 2 if contact is None else 3))
    out_e, count = np.empty((T, 2)), np.zeros(1, np.int64)
    out_lam = drift = constrained = None
    if baumgarte is not None:
        con = core_constraints(model)
        drift = np.zeros(3)  # max |phi|, max |Phi_q v|, failed projections (the core's one array)
        out_lam = np.zeros((T if "lambda" in outputs else 0, con.m))
        constrained = (con, float(baumgarte[0]), float(baumgarte[1]), bool(project), out_lam, drift)
    stats, sw = np.frombuffer(bytearray(_STATS0), solvers.STATS), np.zeros(solvers.MAX_SWITCHES, solvers.SWITCH)
    # the options as the core's Options reads them, in its field order, then the deadline (the core stops past it,
    # status DEADLINE): a tuple, not a dict parsed by name on every call
    options = (*opt, seconds_left())

    def call():
        return _core.run(method, model.core, passive, source, q0, z, float(t0), float(t_end), out_t, out_q, out_v,
                         out_tau, out_w, out_e, count, options, stats, sw, sens, constrained,
                         None if contact is None else contact.core)
    if watch is None:
        base = call()
    else:
        with watch(Samples(out_t, out_q, out_v, out_tau, out_w, out_e, count, None)):
            base = call()
    st = stats[0]
    if st["status"] == DEADLINE:
        raise DeadlineExceeded(f"simulate ran past its deadline at t={float(st['t']):.6g} s of {float(t_end):g} s",
                               done=int(st["samples"]), total=out_t.shape[0])
    p = Samples(out_t, out_q, out_v, out_tau, out_w, out_e, count, base, out_lam,
                None if drift is None else drift[:2], None if drift is None else drift[2:], contact)
    return p, st, sw[:st["switches"]]


#: the core's statuses beyond the solvers' (core/simulation/solver.hpp): a Python torque raised (its exception is
#: raised by the core's run), the deadline passed
ABORTED, DEADLINE = 6, 7
