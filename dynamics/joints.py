"""Joint models in one place (Featherstone 2008, sec. 4.4, ``jcalc``).

Each body ``i`` hangs from its parent by joint ``i``.  The joint's placement ``(Xrot[i], Xpos[i])`` is the
pose of the joint frame in the parent body frame at q = 0; the body frame *is* the joint frame, so the
transform parent -> body is the placement followed by the joint motion:

* revolute / continuous: ``R = Xrot Rot(axis, q)``, ``p = Xpos``            (nq = nv = 1)
  computed as ``R = Xrot + sin q XK + (1 - cos q) XKK`` (Rodrigues' formula Rot = 1 + sin q K + (1 - cos q) K^2,
  K = [axis]x, premultiplied by the placement: ``XK = Xrot K`` and ``XKK = Xrot K^2`` are built with the
  model, so a revolute joint costs its sine and cosine and 36 flops, no 3x3 product)
* prismatic:             ``R = Xrot``,              ``p = Xpos + Xrot axis q`` (nq = nv = 1)
* free (floating):       ``R = Xrot Rot(quat)``,    ``p = Xpos + Xrot xyz``   (nq = 7, nv = 6)
  with q = [x, y, z, qx, qy, qz, qw] and v = [linear, angular] in the body frame (Pinocchio's layout).

The motion subspace is stored per velocity coordinate k as a constant 6-vector ``S[k] = (w, v)`` in the
body frame: (axis, 0) for revolute, (0, axis) for prismatic, unit vectors for the free joint.  Constant S
means the joint bias acceleration is zero in body coordinates (c_J = 0), and ``v_i x (S qd)`` is the only
velocity-product term (eq. 5.8).
"""

from typing import NamedTuple

import numpy as np

from ._numba import inline_kernel
from .spatial import (add, load3, load33, matmul, qexp, qmul, qrot, _quat_rotation, quaternion_sq, rot, scale,
                      skew_poly)

JOINT_REVOLUTE = 0
JOINT_PRISMATIC = 1
JOINT_FREE = 2


class JointKind(NamedTuple):
    """Everything the library knows of one joint type outside its kernels, in one record (as Pinocchio keeps
    one header per joint type): a new joint type is a new record here plus its branches in this module's
    kernels, and nowhere else."""

    code: int  # the kernels' joint code (Tree.jtype)
    urdf: tuple  # the URDF joint types read as this kind
    nq: int  # coordinates in q
    nv: int  # coordinates in v (and a, tau)
    neutral: tuple  # the joint's q at rest (its identity), before joint limits are taken into account
    limited: bool  # URDF position limits, effort, velocity, damping and friction apply to its coordinates
    quaternion: int  # offset in its q of a unit quaternion (x, y, z, w), or -1


KINDS = {
    JOINT_REVOLUTE: JointKind(JOINT_REVOLUTE, ("revolute", "continuous"), 1, 1, (0.0,), True, -1),
    JOINT_PRISMATIC: JointKind(JOINT_PRISMATIC, ("prismatic",), 1, 1, (0.0,), True, -1),
    # q = [x, y, z, qx, qy, qz, qw], v = [linear, angular] in the body frame (Pinocchio's layout)
    JOINT_FREE: JointKind(JOINT_FREE, ("floating",), 7, 6, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0), False, 3),
}

#: nq and nv of each joint code
JOINT_NQ = {c: k.nq for c, k in KINDS.items()}
JOINT_NV = {c: k.nv for c, k in KINDS.items()}

#: URDF joint type -> kernel code
URDF_JOINT_CODES = {name: k.code for k in KINDS.values() for name in k.urdf}


def kind_of(joint_type):
    """The :class:`JointKind` of a URDF joint type name (``model.joint_types`` holds them)."""
    return KINDS[URDF_JOINT_CODES[joint_type]]


def motion_subspace(code, axis):
    """Rows S[k] = (w, v) of the joint's motion subspace in its body frame, shape (nv_joint, 6)."""
    if code == JOINT_REVOLUTE:
        return np.concatenate([axis, np.zeros(3)])[None, :]
    if code == JOINT_PRISMATIC:
        return np.concatenate([np.zeros(3), axis])[None, :]
    S = np.zeros((6, 6))
    S[0:3, 3:6] = np.eye(3)  # v[0:3] is linear velocity
    S[3:6, 0:3] = np.eye(3)  # v[3:6] is angular velocity
    return S


def revolute_terms(Xrot, axis):
    """(XK, XKK) = (Xrot K, Xrot K^2), K = [axis]x: the placement times the terms of Rodrigues' formula."""
    a = np.asarray(axis, float)
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return Xrot @ K, Xrot @ K @ K


@inline_kernel
def _joint_transform(tree, i, q):
    """Pose (R, p) of body i in its parent's frame: placement * joint motion at q."""
    code = tree.jtype[i]
    k = tree.q_idx[i]
    X = load33(tree.Xrot, i)
    p0 = load3(tree.Xpos, i)
    if code == JOINT_REVOLUTE:
        s, t = np.sin(q[k]), 1.0 - np.cos(q[k])
        A, B = tree.XK, tree.XKK
        return (X[0] + s * A[i, 0, 0] + t * B[i, 0, 0], X[1] + s * A[i, 0, 1] + t * B[i, 0, 1],
                X[2] + s * A[i, 0, 2] + t * B[i, 0, 2], X[3] + s * A[i, 1, 0] + t * B[i, 1, 0],
                X[4] + s * A[i, 1, 1] + t * B[i, 1, 1], X[5] + s * A[i, 1, 2] + t * B[i, 1, 2],
                X[6] + s * A[i, 2, 0] + t * B[i, 2, 0], X[7] + s * A[i, 2, 1] + t * B[i, 2, 1],
                X[8] + s * A[i, 2, 2] + t * B[i, 2, 2]), p0
    if code == JOINT_PRISMATIC:
        return X, add(p0, rot(X, scale(q[k], load3(tree.axis, i))))
    R = matmul(X, _quat_rotation(q[k + 3], q[k + 4], q[k + 5], q[k + 6]))
    return R, add(p0, rot(X, (q[k], q[k + 1], q[k + 2])))


@inline_kernel
def _joint_motion(tree, i, qd):
    """S_i qd: the joint's motion (w, v) in the body frame for joint rates (or accelerations) qd."""
    S = tree.S
    w0 = w1 = w2 = v0 = v1 = v2 = 0.0
    for k in range(tree.v_idx[i], tree.v_idx[i] + tree.nv_j[i]):
        x = qd[k]
        w0 += S[k, 0] * x
        w1 += S[k, 1] * x
        w2 += S[k, 2] * x
        v0 += S[k, 3] * x
        v1 += S[k, 4] * x
        v2 += S[k, 5] * x
    return (w0, w1, w2), (v0, v1, v2)


@inline_kernel
def _project_force(tree, i, n, f, tau):
    """tau[dofs of i] = S_i^T (n, f): the generalised force the joint transmits."""
    S = tree.S
    for k in range(tree.v_idx[i], tree.v_idx[i] + tree.nv_j[i]):
        tau[k] = (S[k, 0] * n[0] + S[k, 1] * n[1] + S[k, 2] * n[2]
                  + S[k, 3] * f[0] + S[k, 4] * f[1] + S[k, 5] * f[2])


def joint_matrix(code, axis, qi):
    """4x4 motion of a joint of kind ``code`` at its coordinates ``qi`` (in Python, for lock_joints; the
    kernels use :func:`_joint_transform`)."""
    J = np.eye(4)
    if code == JOINT_REVOLUTE:
        x, y, z = axis
        c, s = np.cos(qi[0]), np.sin(qi[0])
        t = 1 - c
        J[:3, :3] = [[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                     [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                     [t * x * z - s * y, t * y * z + s * x, t * z * z + c]]
    elif code == JOINT_PRISMATIC:
        J[:3, 3] = np.asarray(axis, float) * qi[0]
    else:
        x, y, z, w = qi[3:7]
        n = np.sqrt(x * x + y * y + z * z + w * w)
        x, y, z, w = x / n, y / n, z / n, w / n
        J[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
        J[:3, 3] = qi[:3]
    return J


# -- the configuration manifold, one joint at a time (dynamics.configuration loops over the joints) ---------
#: a unit quaternion whose squared norm is below this is "zero" (it is normalised in the kernels)
ZERO_QUATERNION_SQ = 1e-16


@inline_kernel
def _joint_config_ok(tree, i, q):
    """Joint i's coordinates in q are a configuration: a free joint's quaternion is not zero."""
    return tree.jtype[i] != JOINT_FREE or quaternion_sq(q, tree.q_idx[i] + 3) >= ZERO_QUATERNION_SQ


@inline_kernel
def _joint_limited(tree, i):
    """Joint i's coordinates have position limits (1-dof joints; -inf/inf when the URDF gives none)."""
    return tree.jtype[i] != JOINT_FREE


@inline_kernel
def _joint_integrate_delta(tree, i, q, v, dt, delta):
    """Chart coordinates of joint i after moving with its velocity v for dt (dynamics.configuration): v dt for
    1-dof joints; for the free joint the SE(3) exponential, (R V(theta) v_lin dt, theta = omega dt)."""
    k = tree.v_idx[i]
    if tree.jtype[i] != JOINT_FREE:
        delta[k] = v[k] * dt
        return
    kq = tree.q_idx[i]
    t0, t1, t2 = v[k + 3] * dt, v[k + 4] * dt, v[k + 5] * dt
    phi2 = t0 * t0 + t1 * t1 + t2 * t2
    if phi2 < 1e-8:  # V = 1 + a [t] + b [t]^2 by its series
        a = 0.5 - phi2 / 24.0
        b = 1.0 / 6.0 - phi2 / 120.0
    else:
        phi = np.sqrt(phi2)
        a = (1.0 - np.cos(phi)) / phi2
        b = (phi - np.sin(phi)) / (phi2 * phi)
    x0, x1, x2 = skew_poly(a, b, t0, t1, t2, v[k] * dt, v[k + 1] * dt, v[k + 2] * dt)
    nrm = np.sqrt(q[kq + 3] ** 2 + q[kq + 4] ** 2 + q[kq + 5] ** 2 + q[kq + 6] ** 2)
    p0, p1, p2 = qrot(q[kq + 3] / nrm, q[kq + 4] / nrm, q[kq + 5] / nrm, q[kq + 6] / nrm, x0, x1, x2)
    delta[k], delta[k + 1], delta[k + 2] = p0, p1, p2
    delta[k + 3], delta[k + 4], delta[k + 5] = t0, t1, t2


@inline_kernel
def _joint_retract(tree, i, q0, delta, q):
    """Joint i's part of q = q0 (+) delta: q0 + delta for 1-dof joints; p0 + delta_p and quat0 (x)
    exp(delta_theta), renormalised, for the free joint."""
    k, kq = tree.v_idx[i], tree.q_idx[i]
    if tree.jtype[i] != JOINT_FREE:
        q[kq] = q0[kq] + delta[k]
        return
    for r in range(3):
        q[kq + r] = q0[kq + r] + delta[k + r]
    dx, dy, dz, dw = qexp(delta[k + 3], delta[k + 4], delta[k + 5])
    x, y, z, w = qmul(q0[kq + 3], q0[kq + 4], q0[kq + 5], q0[kq + 6], dx, dy, dz, dw)
    nrm = np.sqrt(x * x + y * y + z * z + w * w)
    q[kq + 3], q[kq + 4], q[kq + 5], q[kq + 6] = x / nrm, y / nrm, z / nrm, w / nrm


@inline_kernel
def _joint_chart_rate(tree, i, q, delta, v, out):
    """Joint i's part of d(delta)/dt: v for 1-dof joints; (R(q) v_lin, Jr(delta_theta)^-1 omega) for the free
    joint, Jr^-1 = 1 + [th]/2 + (1/phi^2 - (1 + cos phi)/(2 phi sin phi)) [th]^2."""
    k = tree.v_idx[i]
    if tree.jtype[i] != JOINT_FREE:
        out[k] = v[k]
        return
    kq = tree.q_idx[i]
    out[k], out[k + 1], out[k + 2] = qrot(q[kq + 3], q[kq + 4], q[kq + 5], q[kq + 6], v[k], v[k + 1], v[k + 2])
    t0, t1, t2 = delta[k + 3], delta[k + 4], delta[k + 5]
    phi2 = t0 * t0 + t1 * t1 + t2 * t2
    if phi2 < 1e-8:
        c = 1.0 / 12.0 + phi2 / 720.0
    else:
        phi = np.sqrt(phi2)
        c = 1.0 / phi2 - (1.0 + np.cos(phi)) / (2.0 * phi * np.sin(phi))
    out[k + 3], out[k + 4], out[k + 5] = skew_poly(0.5, c, t0, t1, t2, v[k + 3], v[k + 4], v[k + 5])


@inline_kernel
def _joint_difference(tree, i, q0, q1, out):
    """Joint i's part of the tangent d with _retract(q0, d) == q1: q1 - q0 for 1-dof joints,
    (p1 - p0, log(quat0^-1 quat1)) for the free joint."""
    k, kq = tree.v_idx[i], tree.q_idx[i]
    if tree.jtype[i] != JOINT_FREE:
        out[k] = q1[kq] - q0[kq]
        return
    for r in range(3):
        out[k + r] = q1[kq + r] - q0[kq + r]
    x, y, z, w = qmul(-q0[kq + 3], -q0[kq + 4], -q0[kq + 5], q0[kq + 6], q1[kq + 3], q1[kq + 4], q1[kq + 5],
                      q1[kq + 6])
    if w < 0.0:  # the shorter way round
        x, y, z, w = -x, -y, -z, -w
    s = np.sqrt(x * x + y * y + z * z)
    ang = 2.0 * np.arctan2(s, w)
    f = 2.0 / w if s < 1e-12 else ang / s
    out[k + 3], out[k + 4], out[k + 5] = f * x, f * y, f * z
