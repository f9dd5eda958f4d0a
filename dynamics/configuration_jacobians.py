"""The Jacobians of the configuration update, joint by joint (Pinocchio's ``dIntegrate`` and ``dDifference``).

``integrate(model, q, v)`` is q (+) v: per joint q + v for 1-dof joints, and M Exp(xi) for the free joint
(M its pose, xi = (v_lin, omega) its body twist, the SE(3) exponential), the spherical (SO(3)) and the planar
joint (SE(2)).  :func:`dynamics.difference` is its inverse, q1 (-) q0: q1 - q0, and Log(M0^-1 M1).  Derivatives with respect to q are in the tangent
space (along q (+) dq, as everywhere in the library), so every Jacobian is (nv, nv) and block diagonal, one
block per joint:

    d(q (+) v)/dq = Ad(Exp(xi))^-1,           d(q (+) v)/dv = Jr(xi)
    d(q1 (-) q0)/dq1 = Jr(d)^-1,              d(q1 (-) q0)/dq0 = -Jr(d)^-1 Ad(Exp(d))^-1,   d = q1 (-) q0

with Ad(R, p) = [[R, [p] R], [0, R]] in the (linear, angular) order of a free joint's v, and Jr the right
Jacobian of SE(3) (Barfoot, "State estimation for robotics", 2017, eqs. 7.83-7.86, with Jr(xi) = Jl(-xi)):

    Jl(xi) = [[Jl(phi), Q(rho, phi)], [0, Jl(phi)]],   Jl(phi) = 1 + (1 - cos t)/t^2 [phi] + (t - sin t)/t^3 [phi]^2

For 1-dof joints the blocks are 1 (and -1 for dq0).  The spherical and planar joints' groups are subgroups of
SE(3) (rotations; motions in the plane of the joint's in-plane directions u, w, about its axis): their blocks
are the rows and columns of the SE(3) blocks at their twist (angular; (v_u, v_w, w_axis)), since the exponential
of a subgroup is the restriction of SE(3)'s.
"""

import numpy as np

from . import checks
from .configuration import difference
from .joints import JOINT_FREE, JOINT_PLANAR, JOINT_SPHERICAL, URDF_JOINT_CODES


def _skew(x):
    return np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])


def _so3_exp(phi):
    t = np.linalg.norm(phi)
    K = _skew(phi)
    if t < 1e-6:
        a, b = 1.0 - t * t / 6.0, 0.5 - t * t / 24.0
    else:
        a, b = np.sin(t) / t, (1.0 - np.cos(t)) / (t * t)
    return np.eye(3) + a * K + b * K @ K


def _so3_left_jacobian(phi):
    """Jl(phi) = 1 + (1 - cos t)/t^2 [phi] + (t - sin t)/t^3 [phi]^2 (series below t = 1e-4)."""
    t = np.linalg.norm(phi)
    K = _skew(phi)
    if t < 1e-4:
        a, b = 0.5 - t * t / 24.0, 1.0 / 6.0 - t * t / 120.0
    else:
        a, b = (1.0 - np.cos(t)) / (t * t), (t - np.sin(t)) / t ** 3
    return np.eye(3) + a * K + b * K @ K


def _se3_q(rho, phi):
    """Barfoot's Q(rho, phi), the upper right block of the left Jacobian of SE(3) (eq. 7.86)."""
    t = np.linalg.norm(phi)
    P, Rh = _skew(phi), _skew(rho)
    if t < 1e-3:
        c1, c2, c3 = 1.0 / 6.0 - t * t / 120.0, 1.0 / 24.0 - t * t / 720.0, 1.0 / 120.0 - t * t / 2520.0
    else:
        s, c = np.sin(t), np.cos(t)
        c1 = (t - s) / t ** 3
        c2 = (t * t + 2.0 * c - 2.0) / (2.0 * t ** 4)
        c3 = (2.0 * t - 3.0 * s + t * c) / (2.0 * t ** 5)
    PR, RP, PRP = P @ Rh, Rh @ P, P @ Rh @ P
    return (0.5 * Rh + c1 * (PR + RP + PRP) + c2 * (P @ PR + RP @ P - 3.0 * PRP)
            + c3 * (PRP @ P + P @ PRP))


def _se3_right_jacobian(xi):
    """Jr(xi) = Jl(-xi), xi = (rho, phi) (linear, angular)."""
    rho, phi = -xi[:3], -xi[3:]
    J = np.zeros((6, 6))
    J[:3, :3] = J[3:, 3:] = _so3_left_jacobian(phi)
    J[:3, 3:] = _se3_q(rho, phi)
    return J


def _se3_adjoint_inverse(xi):
    """Ad(Exp(xi))^-1 = Ad(Exp(-xi)) in (linear, angular) order."""
    R = _so3_exp(-xi[3:])
    p = _so3_left_jacobian(-xi[3:]) @ -xi[:3]
    A = np.zeros((6, 6))
    A[:3, :3] = A[3:, 3:] = R
    A[:3, 3:] = _skew(p) @ R
    return A


#: each multi-dof joint's tangent as a block of the free joint's (linear, angular) twist, in the joint's own
#: basis (for the planar joint: its in-plane directions u, w and its axis; module docstring)
EMBEDDING = {JOINT_FREE: np.arange(6), JOINT_SPHERICAL: np.array([3, 4, 5]), JOINT_PLANAR: np.array([0, 1, 5])}


def _joints(model):
    """(indices of the twist or None for a 1-dof joint, v index, nv) of every joint."""
    out = []
    for jtype, kv, n in zip(model.joint_types, model.v_index, model.nv_joint):
        out.append((EMBEDDING.get(URDF_JOINT_CODES[jtype]), int(kv), int(n)))
    return out


def _twist(idx, x):
    """A joint's tangent x as the 6-vector twist of its subgroup (zero elsewhere)."""
    xi = np.zeros(6)
    xi[idx] = x
    return xi


def integrate_jacobians(model, q, v):
    """(d/dq, d/dv) of integrate(model, q, v), each (nv, nv), q in the tangent space (Pinocchio's dIntegrate
    with ARG0 and ARG1; module docstring).  One state."""
    checks.check_model(model)
    checks.vector("q", q, model.nq)
    v = checks.vector("v", v, model.nv)
    Jq, Jv = np.zeros((model.nv, model.nv)), np.zeros((model.nv, model.nv))
    for idx, kv, n in _joints(model):
        if idx is None:
            Jq[kv, kv] = Jv[kv, kv] = 1.0
            continue
        xi, block = _twist(idx, v[kv:kv + n]), np.ix_(idx, idx)
        Jq[kv:kv + n, kv:kv + n] = _se3_adjoint_inverse(xi)[block]
        Jv[kv:kv + n, kv:kv + n] = _se3_right_jacobian(xi)[block]
    return Jq, Jv


def difference_jacobians(model, q0, q1):
    """(d/dq0, d/dq1) of dynamics.difference(model, q0, q1), each (nv, nv), both in the tangent space
    (Pinocchio's dDifference with ARG0 and ARG1; module docstring).  One state."""
    d = difference(model, q0, q1)
    J0, J1 = np.zeros((model.nv, model.nv)), np.zeros((model.nv, model.nv))
    for idx, kv, n in _joints(model):
        if idx is None:
            J0[kv, kv], J1[kv, kv] = -1.0, 1.0
            continue
        xi, block = _twist(idx, d[kv:kv + n]), np.ix_(idx, idx)
        Jlog = np.linalg.inv(_se3_right_jacobian(xi)[block])
        J1[kv:kv + n, kv:kv + n] = Jlog
        J0[kv:kv + n, kv:kv + n] = -Jlog @ _se3_adjoint_inverse(xi)[block]
    return J0, J1
