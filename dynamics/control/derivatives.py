"""Analytical derivatives of the torque sources with respect to the state: dtau/dq (in the tangent space, nv
columns, along q (+) dq as Pinocchio) and dtau/dv, one function per kind selected at compile time by the
kind's tag like the evaluation (:func:`.dispatch.torque_eval`).

PD, tau = kp e + kd (v_target - v) + tau_ff with e = q_target (-) q the chart difference
(:func:`dynamics.joints._joint_difference`):

    dtau/dv = -diag(kd),    dtau/dq = diag(kp) de/dq,   de/dq block diagonal, one block per joint:
        1-dof joint      -1
        spherical        -Jl(e)^-1                      (log(Exp(-dw) R^T R_target) = e - Jl(e)^-1 dw + ...)
        free             [[-R, 0], [0, -Jl(e_rot)^-1]]  (p + R dv_lin to first order; the position error is in
                                                        the world frame, the velocity in the body frame)
        planar           [[-R(theta), 0], [0, -1]]      (R(theta) the 2x2 rotation of the joint's angle)

  with Jl^-1(phi) = 1 - [phi]/2 + c [phi]^2 the inverse left Jacobian of SO(3) (:func:`dynamics.joints._so3_jr_inv`
  gives c).

Computed torque, tau = RNEA(q, v, a*) - tau_passive(q, v), a* = a_ref + kd (v_ref - v) + kp (q_ref - q):

    dtau/dq = dRNEA/dq (q, v, a*) - M diag(kp) - d tau_passive/dq,
    dtau/dv = dRNEA/dv (q, v, a*) - M diag(kd) - d tau_passive/dv

with the RNEA derivatives and M from :mod:`dynamics.rnea_derivatives` (the model has 1-dof joints only).

Operational space: :mod:`.operational_space_derivatives` (1-dof joints; other models are differenced).

Zero, constant and tables: zero (they depend on t alone).  Python callables have no analytical derivative: their
function returns False and the caller differences the source (:func:`dynamics.simulation.jacobian.source_derivatives`).

These kernels serve the numba simulation's Jacobian (:mod:`dynamics.simulation.jacobian`) until it goes; the public
:func:`dynamics.torque_source_derivatives` and :func:`dynamics.closed_loop_derivatives` and the core's simulations
use the C++ port of every one of them (core/control/derivatives.hpp), the same bits.
"""

import numpy as np
from numba.extending import overload

from .._numba import JIT_OPTIONS, inline_kernel
from ..configuration import _difference
from ..joints import JOINT_FREE, JOINT_PLANAR, JOINT_SPHERICAL, _so3_jr_inv, _unit2
from ..rnea_derivatives import rnea_derivatives_at
from ..spatial import qrot
from .dispatch import (CallableKind, ComputedTorqueKind, ConstantKind, OperationalSpaceKind, PDKind, TableKind,
                       ZeroKind)
from .interpolation import reference_at
from .operational_space_derivatives import operational_space_derivatives
from .passive import passive_derivatives

@inline_kernel
def _zero(dq, dv):
    for r in range(dq.shape[0]):
        for c in range(dq.shape[1]):
            dq[r, c] = 0.0
            dv[r, c] = 0.0


@inline_kernel
def _rotation_error_block(kp, e, k, dq):
    """dq[k:k+3, k:k+3] = -diag(kp) Jl(phi)^-1 with phi = e[k:k+3] (module docstring)."""
    p0, p1, p2 = e[k], e[k + 1], e[k + 2]
    c = _so3_jr_inv(p0, p1, p2)
    # [phi]^2 = phi phi^T - |phi|^2 1
    n2 = p0 * p0 + p1 * p1 + p2 * p2
    P = ((0.0, -p2, p1), (p2, 0.0, -p0), (-p1, p0, 0.0))
    phi = (p0, p1, p2)
    for r in range(3):
        for s in range(3):
            jinv = -0.5 * P[r][s] + c * phi[r] * phi[s]
            if r == s:
                jinv += 1.0 - c * n2
            dq[k + r, k + s] = -kp[k + r] * jinv


@inline_kernel
def _pd_position_block(tree, i, q, e, kp, dq):
    """Joint i's block of diag(kp) de/dq (module docstring)."""
    k, kq, code = tree.v_idx[i], tree.q_idx[i], tree.jtype[i]
    if code == JOINT_SPHERICAL:
        _rotation_error_block(kp, e, k, dq)
    elif code == JOINT_PLANAR:
        c, s = _unit2(q, kq + 2)
        dq[k, k], dq[k, k + 1] = -kp[k] * c, kp[k] * s
        dq[k + 1, k], dq[k + 1, k + 1] = -kp[k + 1] * s, -kp[k + 1] * c
        dq[k + 2, k + 2] = -kp[k + 2]
    elif code == JOINT_FREE:
        x, y, z, w = q[kq + 3], q[kq + 4], q[kq + 5], q[kq + 6]
        for s in range(3):
            col = qrot(x, y, z, w, 1.0 if s == 0 else 0.0, 1.0 if s == 1 else 0.0, 1.0 if s == 2 else 0.0)
            for r in range(3):
                dq[k + r, k + s] = -kp[k + r] * col[r]
        _rotation_error_block(kp, e, k + 3, dq)
    else:
        dq[k, k] = -kp[k]


def _pd_derivatives(tag, src, tree, ps, t, q, v, ws, dq, dv):
    """PD (module docstring); compiled as :func:`source_derivatives_into` for this kind."""
    _zero(dq, dv)
    e = ws[1][0]
    _difference(tree, q, src.qref, e)
    for i in range(tree.jtype.shape[0]):
        _pd_position_block(tree, i, q, e, src.gains[0], dq)
    for k in range(v.shape[0]):
        dv[k, k] = -src.gains[1, k]
    return True


def _computed_torque_derivatives(tag, src, tree, ps, t, q, v, ws, dq, dv):
    """Computed torque (module docstring); compiled as :func:`source_derivatives_into` for this kind."""
    nv = v.shape[0]
    qr, vr, ar = ws[1][0], ws[1][1], ws[1][2]
    reference_at(src.times, src.table, nv, t, qr, vr, ar)
    for i in range(nv):
        ar[i] += src.gains[1, i] * (vr[i] - v[i]) + src.gains[0, i] * (qr[i] - q[i])
    M = np.empty((nv, nv))
    rnea_derivatives_at(tree, q, v, ar, ps.gravity, ps.f_ext, dq, dv, M)
    pq, pv = ws[1][0], ws[1][1]
    passive_derivatives(ps, q, v, pq, pv)
    for r in range(nv):
        for c in range(nv):
            dq[r, c] -= M[r, c] * src.gains[0, c]
            dv[r, c] -= M[r, c] * src.gains[1, c]
        dq[r, r] -= pq[r]
        dv[r, r] -= pv[r]
    return True


def _time_only_derivatives(tag, src, tree, ps, t, q, v, ws, dq, dv):
    """Zero, constant, tables: tau depends on t alone."""
    _zero(dq, dv)
    return True


def _differenced(tag, src, tree, ps, t, q, v, ws, dq, dv):
    """Python callables: no analytical derivative (the caller differences the source)."""
    return False


#: the kinds whose derivative function may return False (the caller then differences the source); the others'
#: callers compile no differences (:func:`dynamics.simulation.jacobian.source_derivatives`)
MAY_BE_DIFFERENCED = {CallableKind, OperationalSpaceKind}

_DERIVATIVES = {ZeroKind: _time_only_derivatives, ConstantKind: _time_only_derivatives,
                TableKind: _time_only_derivatives, PDKind: _pd_derivatives,
                ComputedTorqueKind: _computed_torque_derivatives, CallableKind: _differenced,
                OperationalSpaceKind: operational_space_derivatives}


def source_derivatives_into(tag, src, tree, ps, t, q, v, ws, dq, dv):
    """dq = dtau/dq (tangent space) and dv = dtau/dv (nv, nv) of the source at (t, q, v), analytically; returns
    True, or False (nothing written) for a kind without an analytical derivative.  Compiled code only; arguments
    as :func:`.dispatch.torque_eval`'s."""
    raise NotImplementedError


@overload(source_derivatives_into, jit_options=JIT_OPTIONS)
def _ov_source_derivatives_into(tag, src, tree, ps, t, q, v, ws, dq, dv):
    return _DERIVATIVES[tag.instance_class]
