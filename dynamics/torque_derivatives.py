"""Derivatives of a torque source and of the closed loop it makes with the robot, with respect to the state.

    torque_source_derivatives:  dtau_s/dq, dtau_s/dv of tau_s = source(t, q, v)
    closed_loop_derivatives:    da/dq, da/dv of a = ABA(q, v, tau_s(t, q, v) + tau_p(q, v))

(tau_p the passive torques :func:`dynamics.simulate` adds: damping, friction, limit springs; a is what it
integrates on a model without contact).  q derivatives are in the tangent space (nv columns, along q (+) dq,
Pinocchio's convention, as :func:`dynamics.forward_dynamics_derivatives`).  By the chain rule

    da/dq = da/dq|_tau + M^-1 (dtau_s/dq + dtau_p/dq),      da/dv = da/dv|_tau + M^-1 (dtau_s/dv + dtau_p/dv)

with the ABA derivatives and the sources' analytical derivatives (PD, computed torque, tables, constants, the
operational-space controller on 1-dof joints), both in the C++ core (core/control/derivatives.hpp,
core/control/closed_loop_derivatives.cpp; bindings/control.cpp).  Python callables, and the operational-space
controller on other joints, are differenced (central differences, step 6e-6, along q (+) h e_k).
"""

import numpy as np

from . import _core, checks
from .configuration import _configuration
from .control.passive import Passive
from .control.registry import release_callable
from .control.validation import make_source
from .errors import InputError
from .joints import KINDS
from .simulation.native import core_passive, core_source


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
    """(source, passive, t, q, v), every argument checked and named."""
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
    return src, ps, t, q, v


def _core_call(binding, model, source, t, q, v, passive):
    """binding(model.core, passive, source, t, q, v, out1, out2) on the core's forms of the checked arguments;
    returns (its result, out1, out2).  A callable source's exception is raised as simulate raises it."""
    src, ps, t, q, v = _prepared(model, source, t, q, v, passive)
    nv = model.nv
    out1, out2 = np.empty((nv, nv)), np.empty((nv, nv))
    try:
        result = binding(model.core, core_passive(model, ps), core_source(model, src), t, q, v, out1, out2)
    finally:
        if src.slot >= 0:
            release_callable(src.slot)
    return result, out1, out2


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
    _, dq, dv = _core_call(_core.torque_source_derivatives, model, source, t, q, v,
                           (gravity, limits, limit_stiffness, limit_damping, friction_eps))
    return dq, dv


def closed_loop_derivatives(model, source, t, q, v, *, gravity=None, limits=None, limit_stiffness=1e4,
                            limit_damping=100.0, friction_eps=1e-3):
    """(da_dq, da_dv), each (nv, nv): the derivatives of the acceleration :func:`dynamics.simulate` integrates
    under ``source``, a = forward_dynamics(q, v, tau_source(t, q, v) + tau_passive(q, v)) (module docstring),
    da_dq in the tangent space.  Arguments as :func:`torque_source_derivatives`; a model without constraints
    (contact is not included).  Raises InputError naming the joint when M is singular at q.
    """
    singular, da_dq, da_dv = _core_call(_core.closed_loop_derivatives, model, source, t, q, v,
                                        (gravity, limits, limit_stiffness, limit_damping, friction_eps))
    if singular >= 0:
        raise checks.singular_joint_error(model, singular, "q")
    return da_dq, da_dv
