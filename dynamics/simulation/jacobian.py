"""The Jacobian df/dz of the robot's right-hand side (:mod:`.problem`), assembled from the derivatives of its
parts rather than by differencing the whole: Radau's Newton matrix and the variational equations of
:mod:`.sensitivities` use it.

With z = [delta, v, W_source, W_passive] and f = [c(delta, v), a, v . tau_s, v . tau_p] (c: the chart rate of
v at q = q(delta), :mod:`dynamics.configuration`; a: the ABA's accelerations under tau = tau_s + tau_p):

    dc/d delta  central differences of the chart rate alone (no dynamics; zero for 1-dof joints)
    dc/dv       = c(delta, e_k) column by column (c is linear in v)
    da/d delta  = (da/dq + M^-1 dtau/dq) T,   T = d(tangent at q)/d delta (identity for 1-dof joints)
    da/dv       = da/dv + M^-1 dtau/dv
    d(v . tau)/dz = v^T dtau/dz (+ tau in the v columns)

da/dq (in the tangent space of q, nv columns, Pinocchio's convention), da/dv and M^-1 come from
:func:`aba_derivatives` (Carpentier & Mansard 2018, :mod:`dynamics.aba_derivatives`); dtau_p (damping,
regularised friction, limit springs) is written out
(:func:`dynamics.control.passive.passive_derivatives`); the source's dtau_s analytically (:func:`source_derivatives`, from
:mod:`dynamics.control.derivatives`: PD, computed torque, operational space, tables, constants), or by central
differences of the source alone for Python callables (and the operational-space controller on spherical or
planar joints).  The W columns are zero (f does not
depend on the quadratures).

Contact: after an evaluation that found a contact (since the last Jacobian), tau also holds the generalised
contact force tau_c (:mod:`dynamics.contact`), and its derivatives enter as the source's do: da/d delta +=
M^-1 dtau_c/d delta, da/dv += M^-1 dtau_c/dv, and the contact power's row d(v . tau_c)/dz
(:func:`contact_terms`).  d tau_c/dv is analytical and exact (:mod:`dynamics.contact.force_derivatives`);
d tau_c/d delta is its stiffness part for Radau's Newton matrix, or, in a run with sensitivities (which need it
exact), central differences of the contact force alone.  The contact law is only piecewise smooth (its kink at
touch-down, x = 0, and where (1 + d xdot)_+ clamps): there the differences mix both sides within one difference
step of the kink.  A robot touching nothing skips them.

A problem class carries this as its ``jacobian`` attribute (:func:`.solvers.linalg.problem_jacobian` reaches
it, and falls back to differencing the whole right-hand side for a problem without one).
"""

import numpy as np
from numba import types
from numba.extending import overload

from .._numba import GENERIC_OPTIONS, address, generic_kernel, keep_alive, kernel
from ..aba_derivatives import _aba_derivatives_into, _work_size
from ..configuration import _difference, _integrate_q, chart_rate_in, retract_in
from ..control.derivatives import MAY_BE_DIFFERENCED, source_derivatives_into
from ..control.dispatch import torque_eval
from ..control.passive import passive_derivatives, passive_torques
from ..contact.calls import contact_jacobian, contact_torques, contact_touched
from .solvers.linalg import lu_factor, lu_solve

#: central-difference step (relative): ~ eps^(1/3), the error of the differences of a smooth function
FD_STEP = 6e-6


@kernel
def aba_derivatives(tree, q, v, tau, gravity, f_ext, da_dq, da_dv, Minv):
    """da/dq (tangent space), da/dv, M^-1 at (q, v, tau): the one place that picks the kernel (the analytical
    one of :mod:`dynamics.aba_derivatives`)."""
    buf = np.empty(_work_size(tree.parents.shape[0], v.shape[0]))
    _aba_derivatives_into(tree, q, v, tau, gravity, f_ext, address(buf), da_dq, da_dv, Minv)
    keep_alive(buf)


@generic_kernel
def source_derivatives(p, t, delta, v, dts_dd, dts_dv):
    """d tau_source / d delta (chart coordinates) and / dv: analytical for the kinds that have it
    (:mod:`dynamics.control.derivatives`, in the tangent space, then times T as the ABA's), else by central
    differences of the source alone (:func:`source_differences`)."""
    q = np.empty(p.base.shape[0])
    _retract_at(p, delta, q)
    if source_derivatives_into(p.tag, p.source, p.tree, p.passive, t, q, v, p.ws_source, dts_dd, dts_dv):
        if q.shape[0] != v.shape[0]:
            tangent_to_chart(p.tree, p.base, q, dts_dd)
        return
    source_differences(p.tag, p, t, delta, v, dts_dd, dts_dv)


def source_differences(tag, p, t, delta, v, dts_dd, dts_dv):
    """d tau_source / d delta (chart coordinates) and / dv by central differences of the source alone, for a
    source kind that may need them (:data:`dynamics.control.derivatives.MAY_BE_DIFFERENCED`); compiled to nothing
    for the others, whose derivatives are always analytical, so that their Radau runs do not compile them."""
    raise NotImplementedError("source_differences: compiled code only")


def _no_differences(tag, p, t, delta, v, dts_dd, dts_dv):
    return None


@overload(source_differences, jit_options=GENERIC_OPTIONS)
def _ov_source_differences(tag, p, t, delta, v, dts_dd, dts_dv):
    return _source_differences if tag.instance_class in MAY_BE_DIFFERENCED else _no_differences


def _source_differences(tag, p, t, delta, v, dts_dd, dts_dv):
    """d tau_source / d delta (chart coordinates) and / dv by central differences of the source alone."""
    nv = v.shape[0]
    dt, vt = delta.copy(), v.copy()
    q, tp, tm = np.empty(p.base.shape[0]), np.empty(nv), np.empty(nv)
    for k in range(nv):
        h = FD_STEP * max(1.0, abs(delta[k]))
        dt[k] = delta[k] + h
        _retract_at(p, dt, q)
        torque_eval(p.tag, p.source, p.tree, p.passive, t, q, v, p.ws_source, tp)
        dt[k] = delta[k] - h
        _retract_at(p, dt, q)
        torque_eval(p.tag, p.source, p.tree, p.passive, t, q, v, p.ws_source, tm)
        dt[k] = delta[k]
        for r in range(nv):
            dts_dd[r, k] = (tp[r] - tm[r]) / (2 * h)
    _retract_at(p, delta, q)
    for k in range(nv):
        h = FD_STEP * max(1.0, abs(v[k]))
        vt[k] = v[k] + h
        torque_eval(p.tag, p.source, p.tree, p.passive, t, q, vt, p.ws_source, tp)
        vt[k] = v[k] - h
        torque_eval(p.tag, p.source, p.tree, p.passive, t, q, vt, p.ws_source, tm)
        vt[k] = v[k]
        for r in range(nv):
            dts_dv[r, k] = (tp[r] - tm[r]) / (2 * h)


@generic_kernel
def _contact_at(p, q, v, tau):
    """tau = the generalised contact force at (q, v); returns its power.  Not inlined (called several times)."""
    for k in range(tau.shape[0]):
        tau[k] = 0.0
    return contact_torques(p.contact, p.tree, q, v, tau, None)


def contact_terms(c, p, delta, v, tau_c, dtc_dd, dtc_dv):
    """If an evaluation since the last Jacobian touched something (c = p.contact): tau_c at (delta, v), d tau_c / dv
    (analytical, exact) and d tau_c / d delta (chart coordinates): its stiffness part
    (:mod:`dynamics.contact.force_derivatives`) for Radau's Newton matrix, or, in a run that needs it exact
    (sensitivities), central differences of the contact force alone (module docstring).  Compiled to nothing for a
    problem without contact (as :mod:`dynamics.contact.calls`): its Radau runs compile none of this."""
    raise NotImplementedError("contact_terms: compiled code only")


def _no_contact_terms(c, p, delta, v, tau_c, dtc_dd, dtc_dv):
    return None


@overload(contact_terms, jit_options=GENERIC_OPTIONS)
def _ov_contact_terms(c, p, delta, v, tau_c, dtc_dd, dtc_dv):
    return _no_contact_terms if isinstance(c, types.NoneType) else _contact_terms


def _contact_terms(c, p, delta, v, tau_c, dtc_dd, dtc_dv):
    if not contact_touched(c):
        return
    nv = v.shape[0]
    q = np.empty(p.base.shape[0])
    _retract_at(p, delta, q)
    if contact_jacobian(c, p.tree, q, v, dtc_dd, dtc_dv):  # exact d tau_c / d delta: differenced
        dt = delta.copy()
        tp, tm = np.empty(nv), np.empty(nv)
        for k in range(nv):
            h = FD_STEP * max(1.0, abs(delta[k]))
            dt[k] = delta[k] + h
            _retract_at(p, dt, q)
            _contact_at(p, q, v, tp)
            dt[k] = delta[k] - h
            _retract_at(p, dt, q)
            _contact_at(p, q, v, tm)
            dt[k] = delta[k]
            for r in range(nv):
                dtc_dd[r, k] = (tp[r] - tm[r]) / (2 * h)
        _retract_at(p, delta, q)
    elif q.shape[0] != nv:
        tangent_to_chart(p.tree, p.base, q, dtc_dd)
    _contact_at(p, q, v, tau_c)
    contact_touched(c)  # forget the differences' own contacts


@generic_kernel
def _retract_at(p, delta, q):
    """retract_in from the problem's base, not inlined (see :func:`_chart_rate_at`)."""
    retract_in(p.chart, p.tree, p.base, delta, q)


@generic_kernel
def _chart_rate_at(p, q, delta, v, out):
    """chart_rate_in, not inlined: called several times in one function (numba's inliner would complain)."""
    chart_rate_in(p.chart, p.tree, q, delta, v, out)


@generic_kernel
def chart_derivatives(p, q, delta, v, J):
    """Rows 0..nv of J: dc/d delta (central differences) and dc/dv (c linear in v)."""
    nv = v.shape[0]
    cp, cm, e = np.empty(nv), np.empty(nv), np.zeros(nv)
    for k in range(nv):
        e[k] = 1.0
        _chart_rate_at(p, q, delta, e, cp)
        e[k] = 0.0
        for r in range(nv):
            J[r, nv + k] = cp[r]
    if q.shape[0] == nv:  # 1-dof joints only: c = v
        for r in range(nv):
            for k in range(nv):
                J[r, k] = 0.0
        return
    dt, qt = delta.copy(), np.empty(q.shape[0])
    for k in range(nv):
        h = FD_STEP
        dt[k] = delta[k] + h
        _retract_at(p, dt, qt)
        _chart_rate_at(p, qt, dt, v, cp)
        dt[k] = delta[k] - h
        _retract_at(p, dt, qt)
        _chart_rate_at(p, qt, dt, v, cm)
        dt[k] = delta[k]
        for r in range(nv):
            J[r, k] = (cp[r] - cm[r]) / (2 * h)


@kernel
def tangent_to_chart(tree, base, q, da_dq):
    """da_dq (nv x nv, tangent space at q) <- da_dq T with T = d(tangent)/d delta, from T^-1 = d delta/d e by
    central differences of the chart's inverse (:func:`dynamics.configuration._difference` from base) along
    :func:`dynamics.configuration._integrate_q`.  For models with multi-dof joints only (T = 1 otherwise)."""
    nv = da_dq.shape[0]
    Ti = np.empty((nv, nv))  # stored transposed: Ti[k, r] = (T^-1)[r, k]
    e, dp, dm = np.zeros(nv), np.empty(nv), np.empty(nv)
    for k in range(nv):
        e[k] = 1.0
        _difference(tree, base, _integrate_q(tree, q, e, FD_STEP), dp)
        _difference(tree, base, _integrate_q(tree, q, e, -FD_STEP), dm)
        e[k] = 0.0
        for r in range(nv):
            Ti[k, r] = (dp[r] - dm[r]) / (2 * FD_STEP)
    piv = np.empty(nv, np.int64)
    lu_factor(Ti, piv)  # X T^-1 = da_dq  <=>  T^-T X^T = da_dq^T, one row of da_dq at a time
    row = np.empty(nv)
    for r in range(nv):
        for k in range(nv):
            row[k] = da_dq[r, k]
        lu_solve(Ti, piv, row)
        for k in range(nv):
            da_dq[r, k] = row[k]


@generic_kernel
def robot_jacobian(p, t, z, f0, mag, ne, J, st):
    """J = df/dz at (t, z) for a :class:`.problem.RobotProblem` (module docstring; f0 unused).  Over ~80 lines:
    the assembly of the blocks of one matrix, each a line of the module docstring's table."""
    nv = p.tau_s.shape[0]
    delta, v = z[:nv], z[nv:2 * nv]
    tau_c, dtc_dd, dtc_dv = np.zeros(nv), np.zeros((nv, nv)), np.zeros((nv, nv))
    contact_terms(p.contact, p, delta, v, tau_c, dtc_dd, dtc_dv)
    q = np.empty(p.base.shape[0])
    _retract_at(p, delta, q)
    tau_s, tau = np.empty(nv), np.empty(nv)
    torque_eval(p.tag, p.source, p.tree, p.passive, t, q, v, p.ws_source, tau_s)
    passive_torques(p.passive, q, v, tau)
    tau_p = tau.copy()
    for k in range(nv):
        tau[k] += tau_s[k] + tau_c[k]
    da_dq, da_dv, Minv = np.empty((nv, nv)), np.empty((nv, nv)), np.empty((nv, nv))
    aba_derivatives(p.tree, q, v, tau, p.passive.gravity, p.passive.f_ext, da_dq, da_dv, Minv)
    dts_dd, dts_dv = np.empty((nv, nv)), np.empty((nv, nv))
    source_derivatives(p, t, delta, v, dts_dd, dts_dv)
    dtp_dq, dtp_dv = np.empty(nv), np.empty(nv)
    passive_derivatives(p.passive, q, v, dtp_dq, dtp_dv)
    if q.shape[0] != nv:
        tangent_to_chart(p.tree, p.base, q, da_dq)
    chart_derivatives(p, q, delta, v, J)
    n = J.shape[0]
    for r in range(nv):
        for k in range(nv):
            sd = 0.0
            sv = 0.0
            for m in range(nv):
                sd += Minv[r, m] * (dts_dd[m, k] + dtc_dd[m, k])
                sv += Minv[r, m] * (dts_dv[m, k] + dtc_dv[m, k])
            J[nv + r, k] = da_dq[r, k] + sd + Minv[r, k] * dtp_dq[k]
            J[nv + r, nv + k] = da_dv[r, k] + sv + Minv[r, k] * dtp_dv[k]
    for k in range(nv):  # the powers v . tau_s and v . tau_p
        ps_d = 0.0
        ps_v = tau_s[k]
        for m in range(nv):
            ps_d += v[m] * dts_dd[m, k]
            ps_v += v[m] * dts_dv[m, k]
        J[2 * nv, k] = ps_d
        J[2 * nv, nv + k] = ps_v
        J[2 * nv + 1, k] = v[k] * dtp_dq[k]
        J[2 * nv + 1, nv + k] = tau_p[k] + v[k] * dtp_dv[k]
    for r in range(n):
        for k in range(2 * nv, n):
            J[r, k] = 0.0
    for r in range(2 * nv + 2, n):  # the contact power v . tau_c (zero while nothing touches)
        for k in range(nv):
            pc_d = 0.0
            pc_v = tau_c[k]
            for m in range(nv):
                pc_d += v[m] * dtc_dd[m, k]
                pc_v += v[m] * dtc_dv[m, k]
            J[r, k] = pc_d
            J[r, nv + k] = pc_v
    st.jacobian_evals += 1
