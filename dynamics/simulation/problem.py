"""The robot as an ODE for the solvers: the state, the right-hand side, and what is kept per sample.

The equations of motion (Featherstone 2008, eq. 1.1, solved by the ABA, :mod:`dynamics.aba`):

    M(q) v' + C(q, v) v + g(q) = tau_source(t, q, v) + tau_passive(q, v),      q' = v  (on the manifold)

The integrated state is z = [delta (nv), v (nv), W_source, W_passive (, W_contact)]: delta is the chart
coordinate of q around ``base``, the configuration at the start of the current step
(:mod:`dynamics.configuration`; re-centred after every step by ``rebase`` so free-flyer quaternions stay unit
length), and the quadratures integrate the power of the source and of the passive torques, W' = v . tau, for
the energy balance, and with contact (``contact``: a :class:`dynamics.contact.resolve.PackedContact`) the power
of the contact forces, whose generalised force J_c^T f_c joins the passive torques.  Without contact
(``contact`` None) the contact calls compile to nothing (:mod:`dynamics.contact.resolve`).

:class:`RobotProblem` carries the four functions of the solvers' problem interface
(:mod:`.solvers.interface`) as class attributes.  They read the problem by field name, so a second problem
type with the same fields plus its own (for instance constrained dynamics: a KKT solve after ABA/CRBA)
reuses ``rebase``, ``euler_config`` and ``emit`` and brings only its own ``rhs``, built from
:func:`applied_torques` and :func:`chart_and_velocity`; the solvers and the run entry points
(:mod:`.run`) take it unchanged.
"""

from typing import NamedTuple

import numpy as np

from ..aba import _aba_into, _aba_rest, _rigid_body_terms
from ..aba import _workspace as aba_workspace
from .._numba import borrow, copy_into, generic_kernel, inline_kernel, keep_alive, kernel
from .jacobian import robot_jacobian
from ..configuration import chart_rate_in, chart_tag, _integrate_delta, retract_in
from ..energy import sample_energies
from ..joints import _joint_magnitudes
from ..control.dispatch import kind_tag, source_workspace, torque_eval
from ..control.passive import passive_torques
from ..contact.calls import contact_bias, contact_emit, contact_torques, contact_touchdown, contact_track

NQUAD = 2  # W_source, W_passive; a run with contact has a third, W_contact (z and out_w one longer)


class RobotProblem(NamedTuple):
    """Everything the compiled loop reads and writes, by name."""

    tree: object  # the model's Tree
    passive: object  # torques.Passive (also holds gravity and the external forces)
    source: object  # torques.Source
    ws_source: tuple  # torques.source_workspace(...)
    tag: object  # torques.kind_tag(source.kind): its type selects the one source evaluation compiled
    chart: object  # configuration.chart_tag(model): its type says whether the model has a free joint
    base: np.ndarray  # (nq,) configuration at the start of the current step (the chart's base)
    qbuf: np.ndarray  # (nq,) scratch: the configuration of the state being evaluated
    tau_s: np.ndarray  # (nv,) scratch: source torques
    tau_p: np.ndarray  # (nv,) scratch: passive, then total torques
    ws_aba: tuple  # ABA workspace
    out_t: np.ndarray  # (T,) sample times
    out_q: np.ndarray  # (T, nq) or (0, nq) when q is not kept
    out_v: np.ndarray  # (T, nv) or (0, nv)
    out_tau: np.ndarray  # (T, nv) or (0, nv): applied source torques
    out_w: np.ndarray  # (T, 2) work of the source and passive torques (T, 3): and of the contact forces
    out_e: np.ndarray  # (T, 2) kinetic and potential energy (the report's energy balance)
    count: np.ndarray  # (1,) int64: samples written (also read by the progress bar while the run goes)
    contact: object  # None, or a dynamics.contact.resolve.PackedContact


def robot_problem(model, passive, source, q0, out_t, outputs, contact=None):
    """A :class:`RobotProblem` for a run from q0 that keeps ``outputs`` (of "q", "v", "tau") at ``out_t``;
    ``contact``: None or the run's :class:`dynamics.contact.resolve.PackedContact`."""
    nv, nq, nb = model.nv, model.nq, model.tree.parents.shape[0]
    T = out_t.shape[0]
    ws = aba_workspace(nb, nv)  # (a helper: numpy's allocations from Python, nothing compiled)
    return RobotProblem(
        model.tree, passive, source, source_workspace(source, nb, nv), kind_tag(source.kind), chart_tag(model),
        q0.copy(), np.empty(nq),
        np.empty(nv), np.empty(nv), ws, out_t,
        np.zeros((T if "q" in outputs else 0, nq)), np.zeros((T if "v" in outputs else 0, nv)),
        np.zeros((T if "tau" in outputs else 0, nv)), np.zeros((T, NQUAD + (contact is not None))),
        np.zeros((T, 2)), np.zeros(1, np.int64), contact)


@kernel
def singular_body(tree, q, v, gravity, ws):
    """The ABA at (q, v) with zero torque, as ``rhs`` calls it: -1, or the body whose joint makes M singular
    (simulate's check of q0).  Its arguments borrowed as the run's are, so that the ABA compiled here is the one
    the run uses (one compilation, not two)."""
    nv = v.shape[0]
    owner = np.zeros(2 * nv)
    buf = borrow(owner)
    body = _aba_into(borrow(tree), borrow(q), borrow(v)[0:nv], buf[:nv], borrow(gravity), np.zeros((0, 6)),
                    borrow(ws), buf[nv:])
    keep_alive(owner)
    return body


@inline_kernel
def applied_torques(tag, source, tree, passive, ws_source, contact, tau_s, tau_p, t, q, v, delta):
    """tau_p = source + passive + contact torques at (t, q, v) (the problem's fields of those names; ``delta``:
    q's chart coordinate, :func:`dynamics.contact.calls.contact_torques`); returns the powers (v . tau_source,
    v . tau_passive, contact power)."""
    power_s, power_p = source_and_passive_torques(tag, source, tree, passive, ws_source, tau_s, tau_p, t, q, v)
    power_c = contact_torques(contact, tree, q, v, tau_p, delta)  # its power: sum_k F_k . v_rel_k (= v . J_c^T f_c)
    return power_s, power_p, power_c


@inline_kernel
def source_and_passive_torques(tag, source, tree, passive, ws_source, tau_s, tau_p, t, q, v):
    """tau_p = source + passive torques at (t, q, v) (tau_s: the source's); returns their powers.  (The
    problem's fields, not the problem: with the whole problem bound here a Go1 right-hand side took ~5 % longer;
    compiled code pays for the size of every tuple it binds, and the problem holds dozens of arrays.)"""
    torque_eval(tag, source, tree, passive, t, q, v, ws_source, tau_s)
    passive_torques(passive, q, v, tau_p)
    power_s = 0.0
    power_p = 0.0
    for k in range(v.shape[0]):
        power_s += v[k] * tau_s[k]
        power_p += v[k] * tau_p[k]
        tau_p[k] += tau_s[k]
    return power_s, power_p


@inline_kernel
def chart_and_velocity(chart, tree, base, qbuf, nv, z, dz):
    """qbuf = the configuration of z in the chart around ``base``; dz's chart part = the chart rate of v.
    Returns (q, v) views.  (Fields, not the problem: :func:`source_and_passive_torques`.)"""
    retract_in(chart, tree, base, z[:nv], qbuf)
    chart_rate_in(chart, tree, qbuf, z[:nv], z[nv:2 * nv], dz[:nv])
    return qbuf, z[nv:2 * nv]


@generic_kernel
def rhs(p, t, z, dz):
    """dz = f(t, z): chart rate, ABA accelerations (NaN when the articulated inertia is singular), powers.  The
    contact forces enter the ABA as external body forces (:func:`dynamics.contact.calls.contact_bias`), not as
    generalised torques: the same accelerations, without the contact's own forward and backward passes."""
    nv = p.tau_s.shape[0]
    q, v = chart_and_velocity(p.chart, p.tree, p.base, p.qbuf, nv, z, dz)
    power_s, power_p = source_and_passive_torques(p.tag, p.source, p.tree, p.passive, p.ws_source, p.tau_s, p.tau_p,
                                                  t, q, v)
    ws = p.ws_aba
    # the ABA (dynamics.aba._aba_terms) with the contact forces between its first pass and the others: they act
    # on the bodies as external forces, found from the first pass's poses and velocities (no pass of their own)
    _rigid_body_terms(p.tree, q, v, p.passive.f_ext, ws, True)
    power_c = contact_bias(p.contact, p.tree, ws.d, ws.pA, z[:nv])
    if _aba_rest(p.tree, p.tau_p, p.passive.gravity, ws, dz[nv:2 * nv]) >= 0:
        dz[nv:2 * nv] = np.nan
    quadratures(dz, nv, power_s, power_p, power_c)


@inline_kernel
def quadratures(dz, nv, power_s, power_p, power_c):
    """The quadratures' rates: W_source, W_passive and, in a run with contact, W_contact."""
    dz[2 * nv] = power_s
    dz[2 * nv + 1] = power_p
    if dz.shape[0] > 2 * nv + 2:
        dz[2 * nv + 2] = power_c


@generic_kernel
def rebase(p, t, z, dz, mag):
    """Fold the chart coordinates into ``base``, rewrite dz's chart part for the new chart, and the
    magnitudes of the state for the relative tolerance (|q| per 1-dof coordinate and free-flyer or planar
    position, :func:`dynamics.joints._joint_magnitudes`)."""
    tree, base = p.tree, p.base
    nv = p.tau_s.shape[0]
    retract_in(p.chart, tree, base, z[:nv], p.qbuf)
    copy_into(base, p.qbuf)
    contact_track(p.contact, tree, t, base, z[nv:2 * nv], z[:nv])  # (z's chart part: the step's delta)
    z[:nv] = 0.0
    chart_rate_in(p.chart, tree, base, z[:nv], z[nv:2 * nv], dz[:nv])
    for i in range(tree.jtype.shape[0]):
        _joint_magnitudes(tree, i, base, mag)


@generic_kernel
def euler_config(p, z, h):
    nv = p.tau_s.shape[0]
    _integrate_delta(p.tree, p.base, z[nv:2 * nv], h, z[:nv])


@generic_kernel
def emit(p, j, t, z):
    """Write sample j, and its energies (always: the report's energy balance).  An output the caller did not ask
    for has zero rows: it is neither kept nor, for the torques, computed."""
    nv = p.tau_s.shape[0]
    p.out_t[j] = t
    q = p.out_q[j] if p.out_q.shape[0] > 0 else p.qbuf  # qbuf is free between right-hand-side evaluations
    retract_in(p.chart, p.tree, p.base, z[:nv], q)
    if p.out_v.shape[0] > 0:
        copy_into(p.out_v[j], z[nv:2 * nv])
    if p.out_tau.shape[0] > 0:
        torque_eval(p.tag, p.source, p.tree, p.passive, t, q, z[nv:2 * nv], p.ws_source, p.out_tau[j])
    contact_emit(p.contact, p.tree, j, q, z[nv:2 * nv])
    copy_into(p.out_w[j], z[2 * nv:])
    sample_energies(p.tree, q, z[nv:2 * nv], p.passive.gravity, p.passive.f_ext, p.ws_aba, p.out_e[j])
    p.count[0] = j + 1


@generic_kernel
def touchdown(p):
    """auto's contact test (:func:`.solvers.interface.problem_touchdown`)."""
    return contact_touchdown(p.contact)


RobotProblem.rhs = rhs
RobotProblem.rebase = rebase
RobotProblem.euler_config = euler_config
RobotProblem.emit = emit
RobotProblem.touchdown = touchdown
RobotProblem.jacobian = robot_jacobian  # Radau's Newton matrix (.jacobian: assembled from the parts' derivatives)
