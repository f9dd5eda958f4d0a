"""The Jacobians of the configuration update, joint by joint (Pinocchio's ``dIntegrate`` and ``dDifference``).

``integrate(model, q, v)`` is q (+) v: per joint q + v for 1-dof joints, and M Exp(xi) for the free joint
(M its pose, xi = (v_lin, omega) its body twist, the SE(3) exponential).  :func:`difference` is its inverse,
q1 (-) q0: q1 - q0, and Log(M0^-1 M1) for the free joint.  Derivatives with respect to q are in the tangent
space (along q (+) dq, as everywhere in the library), so every Jacobian is (nv, nv) and block diagonal, one
block per joint:

    d(q (+) v)/dq = Ad(Exp(xi))^-1,           d(q (+) v)/dv = Jr(xi)
    d(q1 (-) q0)/dq1 = Jr(d)^-1,              d(q1 (-) q0)/dq0 = -Jr(d)^-1 Ad(Exp(d))^-1,   d = q1 (-) q0

with Ad(R, p) = [[R, [p] R], [0, R]] in the (linear, angular) order of a free joint's v, and Jr the right
Jacobian of SE(3) (Barfoot, "State estimation for robotics", 2017, eqs. 7.83-7.86, with Jr(xi) = Jl(-xi)):

    Jl(xi) = [[Jl(phi), Q(rho, phi)], [0, Jl(phi)]],   Jl(phi) = 1 + (1 - cos t)/t^2 [phi] + (t - sin t)/t^3 [phi]^2

For 1-dof joints the blocks are 1 (and -1 for dq0).
"""

import numpy as np

from . import checks
from .errors import InputError
from .joints import JOINT_FREE, URDF_JOINT_CODES


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


def _inverse_block_triangular(J):
    """[[A, B], [0, A]]^-1 = [[A^-1, -A^-1 B A^-1], [0, A^-1]]."""
    Ai = np.linalg.inv(J[:3, :3])
    out = np.zeros((6, 6))
    out[:3, :3] = out[3:, 3:] = Ai
    out[:3, 3:] = -Ai @ J[:3, 3:] @ Ai
    return out


def _free_log(q0, q1):
    """The body twist d = Log(M0^-1 M1) of two free-joint coordinates [x, y, z, qx, qy, qz, qw]."""
    from .spatial import _quat_rotation, _rotation_log
    R0 = np.reshape(_quat_rotation(*q0[3:7]), (3, 3))
    R1 = np.reshape(_quat_rotation(*q1[3:7]), (3, 3))
    R = R0.T @ R1
    phi = np.array(_rotation_log(tuple(R.ravel())))
    p = R0.T @ (q1[:3] - q0[:3])
    return np.concatenate([np.linalg.solve(_so3_left_jacobian(phi), p), phi])


def _joints(model):
    """(code, q index, v index) of every joint; refuses the joint kinds this module does not know."""
    out = []
    for name, jtype, kq, kv in zip(model.joint_names, model.joint_types, model.q_index, model.v_index):
        code = URDF_JOINT_CODES[jtype]
        if code != JOINT_FREE and model.nv_joint[model.joint_index(name)] != 1:
            raise InputError(f"model: joint {name!r} of type {jtype!r} has no configuration Jacobian here yet")
        out.append((code, int(kq), int(kv)))
    return out


def difference(model, q0, q1):
    """The tangent vector d (nv,) with integrate(model, q0, d) == q1: q1 - q0 for 1-dof joints, the body twist
    Log(M0^-1 M1) for a free joint (Pinocchio's ``difference``)."""
    q0, q1 = checks.vector("q0", q0, model.nq), checks.vector("q1", q1, model.nq)
    d = np.empty(model.nv)
    for code, kq, kv in _joints(model):
        if code == JOINT_FREE:
            d[kv:kv + 6] = _free_log(q0[kq:kq + 7], q1[kq:kq + 7])
        else:
            d[kv] = q1[kq] - q0[kq]
    return d


def integrate_jacobians(model, q, v):
    """(d/dq, d/dv) of integrate(model, q, v), each (nv, nv), q in the tangent space (Pinocchio's dIntegrate
    with ARG0 and ARG1; module docstring).  One state."""
    checks.check_model(model)
    checks.vector("q", q, model.nq)
    v = checks.vector("v", v, model.nv)
    Jq, Jv = np.zeros((model.nv, model.nv)), np.zeros((model.nv, model.nv))
    for code, kq, kv in _joints(model):
        if code == JOINT_FREE:
            xi = v[kv:kv + 6]
            Jq[kv:kv + 6, kv:kv + 6] = _se3_adjoint_inverse(xi)
            Jv[kv:kv + 6, kv:kv + 6] = _se3_right_jacobian(xi)
        else:
            Jq[kv, kv] = Jv[kv, kv] = 1.0
    return Jq, Jv


def difference_jacobians(model, q0, q1):
    """(d/dq0, d/dq1) of difference(model, q0, q1), each (nv, nv), both in the tangent space (Pinocchio's
    dDifference with ARG0 and ARG1; module docstring).  One state."""
    checks.check_model(model)
    d = difference(model, q0, q1)
    J0, J1 = np.zeros((model.nv, model.nv)), np.zeros((model.nv, model.nv))
    for code, kq, kv in _joints(model):
        if code == JOINT_FREE:
            Jlog = _inverse_block_triangular(_se3_right_jacobian(d[kv:kv + 6]))
            J1[kv:kv + 6, kv:kv + 6] = Jlog
            J0[kv:kv + 6, kv:kv + 6] = -Jlog @ _se3_adjoint_inverse(d[kv:kv + 6])
        else:
            J0[kv, kv], J1[kv, kv] = -1.0, 1.0
    return J0, J1
