"""The passive joint torques the simulator always adds (the laws are in :mod:`dynamics.torques`' docstring):
viscous damping, regularised Coulomb friction and, with ``limits="spring"``, a Hunt-Crossley spring-damper at
the position limits."""

from typing import NamedTuple

import numpy as np

from .._numba import inline_kernel


class Passive(NamedTuple):
    """Model and simulation parameters of the passive joint torques (numba-friendly)."""

    damping: np.ndarray  # (nv,)
    friction: np.ndarray  # (nv,)
    friction_eps: float
    limits: int  # 0 none, 1 spring
    lower: np.ndarray  # (nv,)
    upper: np.ndarray  # (nv,)
    qpos: np.ndarray  # (nv,) int64: q index of a 1-dof coordinate, -1 for free-joint coordinates
    k_limit: float
    b_limit: float
    gravity: np.ndarray  # (3,)
    f_ext: np.ndarray  # (0, 6)



@inline_kernel
def passive_torques(ps, q, v, out):
    """out = damping + friction + limit-spring torques (module docstring)."""
    for k in range(v.shape[0]):
        tq = -ps.damping[k] * v[k]
        if ps.friction[k] != 0.0:
            tq -= ps.friction[k] * np.tanh(v[k] / ps.friction_eps)
        if ps.limits == 1 and ps.qpos[k] >= 0:
            x = q[ps.qpos[k]]
            if x < ps.lower[k]:
                pen = ps.lower[k] - x
                tq += max(0.0, ps.k_limit * pen - ps.b_limit * pen * v[k])
            elif x > ps.upper[k]:
                pen = x - ps.upper[k]
                tq -= max(0.0, ps.k_limit * pen + ps.b_limit * pen * v[k])
        out[k] = tq


@inline_kernel
def passive_derivatives(ps, q, v, dq, dv):
    """Diagonals of d tau_passive/dq (1-dof coordinates; zero for the others) and d tau_passive/dv, the laws of
    :func:`passive_torques` differentiated: -b, -mu (1 - tanh^2(v/eps))/eps, and the Hunt-Crossley springs'
    -(k +- b v), -b pen while they push."""
    for k in range(v.shape[0]):
        dq[k] = 0.0
        dv[k] = -ps.damping[k]
        if ps.friction[k] != 0.0:
            th = np.tanh(v[k] / ps.friction_eps)
            dv[k] -= ps.friction[k] * (1.0 - th * th) / ps.friction_eps
        if ps.limits == 1 and ps.qpos[k] >= 0:
            x = q[ps.qpos[k]]
            if x < ps.lower[k]:
                pen = ps.lower[k] - x
                if ps.k_limit * pen - ps.b_limit * pen * v[k] > 0.0:
                    dq[k] = -(ps.k_limit - ps.b_limit * v[k])
                    dv[k] -= ps.b_limit * pen
            elif x > ps.upper[k]:
                pen = x - ps.upper[k]
                if ps.k_limit * pen + ps.b_limit * pen * v[k] > 0.0:
                    dq[k] = -(ps.k_limit + ps.b_limit * v[k])
                    dv[k] -= ps.b_limit * pen
