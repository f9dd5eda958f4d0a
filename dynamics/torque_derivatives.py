"""Derivatives of a torque source and of the closed loop it makes with the robot, with respect to the state.

    torque_source_derivatives:  dtau_s/dq, dtau_s/dv of tau_s = source(t, q, v)
    closed_loop_derivatives:    da/dq, da/dv of a = ABA(q, v, tau_s(t, q, v) + tau_p(q, v))

(tau_p the passive torques :func:`dynamics.simulate` adds: damping, friction, limit springs; a is what it
integrates on a model without contact).  q derivatives are in the tangent space (nv columns, along q (+) dq,
Pinocchio's convention, as :func:`dynamics.forward_dynamics_derivatives`).  By the chain rule

    da/dq = da/dq|_tau + M^-1 (dtau_s/dq + dtau_p/dq),      da/dv = da/dv|_tau + M^-1 (dtau_s/dv + dtau_p/dv)

with the ABA derivatives of :mod:`dynamics.aba_derivatives` and the sources' analytical derivatives of
:mod:`dynamics.control.derivatives` (PD, computed torque, tables, constants).  The operational-space
controller and Python callables are differenced (central differences, step 6e-6, along q (+) h e_k).
"""

import numpy as np

from . import checks
from ._numba import address, keep_alive, kernel
from .aba_derivatives import _aba_derivatives_into, _work_size
from .configuration import _configuration
from .control.derivatives import source_derivatives_tangent
from .control.dispatch import kind_tag, source_workspace, torque_eval
from .control.passive import Passive, passive_derivatives, passive_torques
from .control.registry import release_callable
from .control.validation import make_source
from .errors import InputError
from .joints import KINDS


@kernel
def _closed_loop_kernel(tag, src, tree, ps, t, q, v, ws, da_dq, da_dv):
    """da/dq, da/dv of the closed loop (module docstring); returns -1 or a body whose joint makes M singular."""
    nv = v.shape[0]
    dq, dv = np.empty((nv, nv)), np.empty((nv, nv))
    source_derivatives_tangent(tag, src, tree, ps, t, q, v, ws, dq, dv)
    tau, pas, pq, pv = np.empty(nv), np.empty(nv), np.empty(nv), np.empty(nv)
    torque_eval(tag, src, tree, ps, t, q, v, ws, tau)
    passive_torques(ps, q, v, pas)
    passive_derivatives(ps, q, v, pq, pv)
    for k in range(nv):
        tau[k] += pas[k]
        dq[k, k] += pq[k]
        dv[k, k] += pv[k]
    buf = np.empty(_work_size(tree.parents.shape[0], nv))
    Minv = np.empty((nv, nv))
    singular = _aba_derivatives_into(tree, q, v, tau, ps.gravity, ps.f_ext, address(buf), da_dq, da_dv, Minv)
    keep_alive(buf)
    if singular >= 0:
        return singular
    for r in range(nv):
        for c in range(nv):
            sq = sv = 0.0
            for m in range(nv):
                sq += Minv[r, m] * dq[m, c]
                sv += Minv[r, m] * dv[m, c]
            da_dq[r, c] += sq
            da_dv[r, c] += sv
    return -1


def _passive(model, gravity, limits, limit_stiffness, limit_damping, friction_eps):
    """The passive torques' parameters, checked as :func:`dynamics.simulate` checks them."""
    if limits not in (None, "spring"):
        raise InputError(f"limits: expected None or 'spring', got {limits!r}")
    k = checks.real_number("limit_stiffness", limit_stiffness, lo=0.0)
    b = checks.real_number("limit_damping", limit_damping, lo=0.0)
    eps = checks.real_number("friction_eps", friction_eps, lo=0.0, lo_open=True)
    qpos = np.full(model.nv, -1, np.int64)
    for i, code in enumerate(model.tree.jtype):
        if KINDS[int(code)].limited:
            qpos[model.tree.v_idx[i]] = model.tree.q_idx[i]
    return Passive(np.ascontiguousarray(model.damping, float), np.ascontiguousarray(model.friction, float), eps,
                   1 if limits == "spring" else 0, np.ascontiguousarray(model.lower, float),
                   np.ascontiguousarray(model.upper, float), qpos, k, b, checks.gravity_vector(model, gravity),
                   np.zeros((0, 6)))


def _prepared(model, source, t, q, v, passive):
    """(source, tag, passive, t, q, v, workspace), every argument checked and named."""
    checks.check_model(model)
    if getattr(model, "constraints", None):
        raise InputError("model: these derivatives are of the unconstrained closed loop; this model has "
                         "constraints (differentiate the model without them)")
    t = checks.real_number("t", t)
    q = _configuration(model, "q", q)
    v = checks.vector("v", v, model.nv)
    ps = _passive(model, *passive)
    try:
        src = make_source(model, source)
    except InputError as e:  # make_source names simulate's argument, torque
        msg = str(e)
        raise InputError("source" + msg[len("torque"):] if msg.startswith("torque") else msg) from None
    return src, kind_tag(src.kind), ps, t, q, v, source_workspace(src, model.tree.parents.shape[0], model.nv)


def torque_source_derivatives(model, source, t, q, v, *, gravity=None, limits=None, limit_stiffness=1e4,
                              limit_damping=100.0, friction_eps=1e-3):
    """(dtau_dq, dtau_dv), each (nv, nv): the derivatives of the torque the source applies at (t, q, v), with
    dtau_dq in the tangent space (module docstring).

    source: any ``torque=`` argument of :func:`dynamics.simulate` (None, an (nv,) array, ``Table``, ``PD``,
    ``ComputedTorque``, ``OperationalSpace``, ``Target``, a callable f(t, q, v)).  Analytical for all but
    callables and the operational-space controller on spherical or planar joints (central differences).  The keyword arguments are simulate's
    passive-torque settings (the computed torque cancels the passive torques, so they enter its derivatives).
    One state: t a float, q (nq,), v (nv,).
    """
    src, tag, ps, t, q, v, ws = _prepared(model, source, t, q, v,
                                          (gravity, limits, limit_stiffness, limit_damping, friction_eps))
    dq, dv = np.empty((model.nv, model.nv)), np.empty((model.nv, model.nv))
    try:
        source_derivatives_tangent(tag, src, model.tree, ps, t, q, v, ws, dq, dv)
    finally:
        if src.slot >= 0:
            release_callable(src.slot)
    return dq, dv


def closed_loop_derivatives(model, source, t, q, v, *, gravity=None, limits=None, limit_stiffness=1e4,
                            limit_damping=100.0, friction_eps=1e-3):
    """(da_dq, da_dv), each (nv, nv): the derivatives of the acceleration :func:`dynamics.simulate` integrates
    under ``source``, a = forward_dynamics(q, v, tau_source(t, q, v) + tau_passive(q, v)) (module docstring),
    da_dq in the tangent space.  Arguments as :func:`torque_source_derivatives`; a model without constraints
    (contact is not included).  Raises InputError naming the joint when M is singular at q.
    """
    src, tag, ps, t, q, v, ws = _prepared(model, source, t, q, v,
                                          (gravity, limits, limit_stiffness, limit_damping, friction_eps))
    da_dq, da_dv = np.empty((model.nv, model.nv)), np.empty((model.nv, model.nv))
    try:
        singular = _closed_loop_kernel(tag, src, model.tree, ps, t, q, v, ws, da_dq, da_dv)
    finally:
        if src.slot >= 0:
            release_callable(src.slot)
    if singular >= 0:
        raise checks.singular_joint_error(model, singular, "q")
    return da_dq, da_dv
