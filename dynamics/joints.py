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
* spherical:             ``R = Xrot Rot(quat)``,    ``p = Xpos``              (nq = 4, nv = 3)
  with q = [qx, qy, qz, qw] and v = the angular velocity in the body frame (Pinocchio's JointModelSpherical).
* planar:                ``R = Xrot Rot(axis, theta)``, ``p = Xpos + Xrot (x u + y w)``  (nq = 4, nv = 3)
  with q = [x, y, cos theta, sin theta] and v = [vx, vy, wz] in the body frame (Pinocchio's JointModelPlanar):
  the body moves in the plane normal to ``axis`` (the URDF's meaning of a planar joint's axis), whose in-plane
  directions (u, w) are the first two columns of :func:`plane_frame`, the rotation taking z onto the axis
  (u = x, w = y for the usual axis z, where it is exactly Pinocchio's joint).  R uses the revolute terms XK,
  XKK of the axis, with (cos theta, sin theta) normalised first, as a quaternion is.

The motion subspace is stored per velocity coordinate k as a constant 6-vector ``S[k] = (w, v)`` in the
body frame: (axis, 0) for revolute, (0, axis) for prismatic, unit vectors for the free and spherical joints,
(0, u), (0, w), (axis, 0) for the planar joint.  Constant S means the joint bias acceleration is zero in body
coordinates (c_J = 0), and ``v_i x (S qd)`` is the only velocity-product term (eq. 5.8): every algorithm
works for every joint through ``S`` and :func:`_joint_transform` alone.  (For the planar joint: the body
twist is T^-1 dT = (theta' axis, Rot(axis, -theta) (x' u + y' w)), so with v the in-plane velocity in the
body frame, x' u + y' w = Rot(axis, theta) (vx u + vy w), and S v is that twist for every q.)
"""

from typing import NamedTuple

import numpy as np

from ._numba import inline_kernel
from .spatial import (add, load3, load33, matmul, qexp, qmul, qrot, _quat_rotation, quaternion_sq, rot, scale,
                      skew_poly)

JOINT_REVOLUTE = 0
JOINT_PRISMATIC = 1
JOINT_FREE = 2
JOINT_SPHERICAL = 3
JOINT_PLANAR = 4


class JointKind(NamedTuple):
    """Everything the library knows of one joint type outside its kernels, in one record (as Pinocchio keeps
    one header per joint type): a new joint type is a new record here plus its branches in this module's
    kernels (:func:`_joint_transform`, :func:`motion_subspace`, :func:`joint_matrix` and the configuration
    manifold's), and nowhere else: the algorithms see a joint only through S and its transform, the checks,
    lock_joints, the simulation's chart and tolerances through these records and kernels.  (The URDF reader
    adds only what the URDF says of a type: a continuous joint has no position limits, a planar joint's axis
    is its plane's normal.)"""

    code: int  # the kernels' joint code (Tree.jtype)
    urdf: tuple  # the URDF joint types read as this kind
    nq: int  # coordinates in q
    nv: int  # coordinates in v (and a, tau)
    neutral: tuple  # the joint's q at rest (its identity), before joint limits are taken into account
    limited: bool  # URDF position limits, effort, velocity, damping and friction apply to its coordinates
    quaternion: int  # offset in its q of a unit quaternion (x, y, z, w), or -1
    #: the URDF <axis> is read (checked non-zero, normalised); otherwise the model stores a zero axis
    axis: bool = True
    #: (offset in its q, size) of the block of q that is a unit vector (a quaternion, or (cos, sin)), or ()
    unit: tuple = ()
    #: its coordinates as messages spell them (a locked value), "" for one number
    q_layout: str = ""


KINDS = {
    JOINT_REVOLUTE: JointKind(JOINT_REVOLUTE, ("revolute", "continuous"), 1, 1, (0.0,), True, -1),
    JOINT_PRISMATIC: JointKind(JOINT_PRISMATIC, ("prismatic",), 1, 1, (0.0,), True, -1),
    # q = [x, y, z, qx, qy, qz, qw], v = [linear, angular] in the body frame (Pinocchio's layout)
    JOINT_FREE: JointKind(JOINT_FREE, ("floating",), 7, 6, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0), False, 3,
                          axis=False, unit=(3, 4), q_layout="[x, y, z, qx, qy, qz, qw]"),
    # q = [qx, qy, qz, qw], v = angular velocity in the body frame (Pinocchio's JointModelSpherical)
    JOINT_SPHERICAL: JointKind(JOINT_SPHERICAL, ("spherical",), 4, 3, (0.0, 0.0, 0.0, 1.0), False, 0,
                               axis=False, unit=(0, 4), q_layout="[qx, qy, qz, qw]"),
    # q = [x, y, cos theta, sin theta], v = [vx, vy, wz] in the body frame (Pinocchio's JointModelPlanar)
    JOINT_PLANAR: JointKind(JOINT_PLANAR, ("planar",), 4, 3, (0.0, 0.0, 1.0, 0.0), False, -1,
                            unit=(2, 2), q_layout="[x, y, cos theta, sin theta]"),
}

#: nq and nv of each joint code
JOINT_NQ = {c: k.nq for c, k in KINDS.items()}
JOINT_NV = {c: k.nv for c, k in KINDS.items()}

#: URDF joint type -> kernel code
URDF_JOINT_CODES = {name: k.code for k in KINDS.values() for name in k.urdf}


def kind_of(joint_type):
    """The :class:`JointKind` of a URDF joint type name (``model.joint_types`` holds them)."""
    return KINDS[URDF_JOINT_CODES[joint_type]]


def plane_frame(axis):
    """The rotation Ra whose third column is the unit ``axis``: the planar joint's plane is spanned by its first
    two columns.  The smallest rotation taking z onto the axis (Ra = 1 for z), from -z by way of a half turn
    about x (so that 1 + z.axis never nears zero): deterministic, so a model built twice moves the same way."""
    a = np.asarray(axis, float)
    flip = a[2] < 0.0
    if flip:  # Rx(pi) Ra' with Ra' z = Rx(pi)^T a = (ax, -ay, -az)
        a = np.array([a[0], -a[1], -a[2]])
    x, y, z = a
    f = 1.0 / (1.0 + z)
    R = np.array([[1.0 - f * x * x, -f * x * y, x], [-f * x * y, 1.0 - f * y * y, y], [-x, -y, z]])
    return np.diag([1.0, -1.0, -1.0]) @ R if flip else R


def motion_subspace(code, axis):
    """Rows S[k] = (w, v) of the joint's motion subspace in its body frame, shape (nv_joint, 6)."""
    if code == JOINT_REVOLUTE:
        return np.concatenate([axis, np.zeros(3)])[None, :]
    if code == JOINT_PRISMATIC:
        return np.concatenate([np.zeros(3), axis])[None, :]
    if code == JOINT_SPHERICAL:
        return np.concatenate([np.eye(3), np.zeros((3, 3))], axis=1)
    if code == JOINT_PLANAR:
        Ra = plane_frame(axis)
        S = np.zeros((3, 6))
        S[0, 3:6], S[1, 3:6], S[2, 0:3] = Ra[:, 0], Ra[:, 1], Ra[:, 2]
        return S
    S = np.zeros((6, 6))
    S[0:3, 3:6] = np.eye(3)  # v[0:3] is linear velocity
    S[3:6, 0:3] = np.eye(3)  # v[3:6] is angular velocity
    return S


def revolute_terms(Xrot, axis):
    """(XK, XKK) = (Xrot K, Xrot K^2), K = [axis]x: the placement times the terms of Rodrigues' formula."""
    a = np.asarray(axis, float)
    K = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return Xrot @ K, Xrot @ K @ K


#: the joint codes whose rotation is Rodrigues' formula about the axis (XK, XKK are built for them)
ROTATES_ABOUT_AXIS = (JOINT_REVOLUTE, JOINT_PLANAR)


@inline_kernel
def _rodrigues(tree, i, X, s, t):
    """Xrot Rot(axis, theta) = X + s XK + t XKK for s = sin theta, t = 1 - cos theta (a 9-tuple)."""
    A, B = tree.XK, tree.XKK
    return (X[0] + s * A[i, 0, 0] + t * B[i, 0, 0], X[1] + s * A[i, 0, 1] + t * B[i, 0, 1],
            X[2] + s * A[i, 0, 2] + t * B[i, 0, 2], X[3] + s * A[i, 1, 0] + t * B[i, 1, 0],
            X[4] + s * A[i, 1, 1] + t * B[i, 1, 1], X[5] + s * A[i, 1, 2] + t * B[i, 1, 2],
            X[6] + s * A[i, 2, 0] + t * B[i, 2, 0], X[7] + s * A[i, 2, 1] + t * B[i, 2, 1],
            X[8] + s * A[i, 2, 2] + t * B[i, 2, 2])


@inline_kernel
def _joint_transform(tree, i, q):
    """Pose (R, p) of body i in its parent's frame: placement * joint motion at q."""
    code = tree.jtype[i]
    k = tree.q_idx[i]
    X = load33(tree.Xrot, i)
    p0 = load3(tree.Xpos, i)
    if code == JOINT_REVOLUTE:
        return _rodrigues(tree, i, X, np.sin(q[k]), 1.0 - np.cos(q[k])), p0
    if code == JOINT_PRISMATIC:
        return X, add(p0, rot(X, scale(q[k], load3(tree.axis, i))))
    if code == JOINT_SPHERICAL:
        return matmul(X, _quat_rotation(q[k], q[k + 1], q[k + 2], q[k + 3])), p0
    if code == JOINT_PLANAR:
        nrm = np.sqrt(q[k + 2] * q[k + 2] + q[k + 3] * q[k + 3])
        S, kv = tree.S, tree.v_idx[i]
        x, y = q[k], q[k + 1]
        d = (x * S[kv, 3] + y * S[kv + 1, 3], x * S[kv, 4] + y * S[kv + 1, 4], x * S[kv, 5] + y * S[kv + 1, 5])
        return _rodrigues(tree, i, X, q[k + 3] / nrm, 1.0 - q[k + 2] / nrm), add(p0, rot(X, d))
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


def _rotation_matrix(axis, c, s):
    """Rot(axis, theta) for a unit axis from cos theta and sin theta (Rodrigues' formula)."""
    x, y, z = axis
    t = 1 - c
    return np.array([[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                     [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                     [t * x * z - s * y, t * y * z + s * x, t * z * z + c]])


def _quaternion_matrix(quat):
    x, y, z, w = np.asarray(quat, float) / np.linalg.norm(quat)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def joint_matrix(code, axis, qi):
    """4x4 motion of a joint of kind ``code`` at its coordinates ``qi`` (in Python, for lock_joints; the
    kernels use :func:`_joint_transform`)."""
    J = np.eye(4)
    if code == JOINT_REVOLUTE:
        J[:3, :3] = _rotation_matrix(axis, np.cos(qi[0]), np.sin(qi[0]))
    elif code == JOINT_PRISMATIC:
        J[:3, 3] = np.asarray(axis, float) * qi[0]
    elif code == JOINT_SPHERICAL:
        J[:3, :3] = _quaternion_matrix(qi)
    elif code == JOINT_PLANAR:
        n = np.hypot(qi[2], qi[3])
        Ra = plane_frame(axis)
        J[:3, :3] = _rotation_matrix(axis, qi[2] / n, qi[3] / n)
        J[:3, 3] = qi[0] * Ra[:, 0] + qi[1] * Ra[:, 1]
    else:
        J[:3, :3] = _quaternion_matrix(qi[3:7])
        J[:3, 3] = qi[:3]
    return J


# -- the configuration manifold, one joint at a time (dynamics.configuration loops over the joints) ---------
#: a unit quaternion (or a planar joint's (cos, sin)) whose squared norm is below this is "zero" (it is
#: normalised in the kernels)
ZERO_QUATERNION_SQ = 1e-16


@inline_kernel
def _joint_config_ok(tree, i, q):
    """Joint i's coordinates in q are a configuration: its unit quaternion or (cos, sin) is not zero."""
    code, k = tree.jtype[i], tree.q_idx[i]
    if code == JOINT_FREE:
        return quaternion_sq(q, k + 3) >= ZERO_QUATERNION_SQ
    if code == JOINT_SPHERICAL:
        return quaternion_sq(q, k) >= ZERO_QUATERNION_SQ
    if code == JOINT_PLANAR:
        return q[k + 2] * q[k + 2] + q[k + 3] * q[k + 3] >= ZERO_QUATERNION_SQ
    return True


@inline_kernel
def _joint_magnitudes(tree, i, q, mag):
    """mag[dofs of i] = |the coordinate of q that moves alone with each velocity coordinate in the chart| (an
    angle, a position), 0 for a quaternion's or a planar joint's angle: the scale of the simulation's relative
    tolerance."""
    k, kq, code = tree.v_idx[i], tree.q_idx[i], tree.jtype[i]
    if code == JOINT_FREE or code == JOINT_PLANAR:
        n = 3 if code == JOINT_FREE else 2
        for r in range(tree.nv_j[i]):
            mag[k + r] = abs(q[kq + r]) if r < n else 0.0
    elif code == JOINT_SPHERICAL:
        mag[k], mag[k + 1], mag[k + 2] = 0.0, 0.0, 0.0
    else:
        mag[k] = abs(q[kq])


@inline_kernel
def _se3_v(t0, t1, t2):
    """(a, b) of V(theta) = 1 + a [theta] + b [theta]^2, the SE(3) exponential's translation term."""
    phi2 = t0 * t0 + t1 * t1 + t2 * t2
    if phi2 < 1e-8:  # by its series
        return 0.5 - phi2 / 24.0, 1.0 / 6.0 - phi2 / 120.0
    phi = np.sqrt(phi2)
    return (1.0 - np.cos(phi)) / phi2, (phi - np.sin(phi)) / (phi2 * phi)


@inline_kernel
def _so3_jr_inv(t0, t1, t2):
    """c of Jr(theta)^-1 = 1 + [theta]/2 + c [theta]^2 (and of V(theta)^-1 = 1 - [theta]/2 + c [theta]^2)."""
    phi2 = t0 * t0 + t1 * t1 + t2 * t2
    if phi2 < 1e-8:
        return 1.0 / 12.0 + phi2 / 720.0
    phi = np.sqrt(phi2)
    return 1.0 / phi2 - (1.0 + np.cos(phi)) / (2.0 * phi * np.sin(phi))


@inline_kernel
def _unit2(q, k):
    """(cos theta, sin theta) of a planar joint, normalised."""
    n = np.sqrt(q[k] * q[k] + q[k + 1] * q[k + 1])
    return q[k] / n, q[k + 1] / n


@inline_kernel
def _joint_integrate_delta(tree, i, q, v, dt, delta):
    """Chart coordinates of joint i after moving with its velocity v for dt (dynamics.configuration): v dt for
    1-dof joints; for the free joint the SE(3) exponential, (R V(theta) v_lin dt, theta = omega dt); omega dt for
    the spherical joint; for the planar joint the SE(2) exponential, (R(theta0) V2(theta) (vx, vy) dt, theta =
    wz dt), V2 = [[sin t / t, -(1 - cos t) / t], [(1 - cos t) / t, sin t / t]]."""
    k, kq, code = tree.v_idx[i], tree.q_idx[i], tree.jtype[i]
    if code == JOINT_REVOLUTE or code == JOINT_PRISMATIC:
        delta[k] = v[k] * dt
        return
    if code == JOINT_SPHERICAL:
        delta[k], delta[k + 1], delta[k + 2] = v[k] * dt, v[k + 1] * dt, v[k + 2] * dt
        return
    if code == JOINT_PLANAR:
        t = v[k + 2] * dt
        if abs(t) < 1e-4:  # sin t / t and (1 - cos t) / t by their series
            a, b = 1.0 - t * t / 6.0 * (1.0 - t * t / 20.0), t / 2.0 * (1.0 - t * t / 12.0)
        else:
            a, b = np.sin(t) / t, (1.0 - np.cos(t)) / t
        x, y = (a * v[k] - b * v[k + 1]) * dt, (b * v[k] + a * v[k + 1]) * dt
        c, s = _unit2(q, kq + 2)
        delta[k], delta[k + 1], delta[k + 2] = c * x - s * y, s * x + c * y, t
        return
    t0, t1, t2 = v[k + 3] * dt, v[k + 4] * dt, v[k + 5] * dt
    a, b = _se3_v(t0, t1, t2)
    x0, x1, x2 = skew_poly(a, b, t0, t1, t2, v[k] * dt, v[k + 1] * dt, v[k + 2] * dt)
    nrm = np.sqrt(quaternion_sq(q, kq + 3))
    p0, p1, p2 = qrot(q[kq + 3] / nrm, q[kq + 4] / nrm, q[kq + 5] / nrm, q[kq + 6] / nrm, x0, x1, x2)
    delta[k], delta[k + 1], delta[k + 2] = p0, p1, p2
    delta[k + 3], delta[k + 4], delta[k + 5] = t0, t1, t2


@inline_kernel
def _retract_quaternion(q0, kq, d0, d1, d2, q):
    """q[kq:kq + 4] = q0[kq:kq + 4] (x) exp(d), renormalised."""
    dx, dy, dz, dw = qexp(d0, d1, d2)
    x, y, z, w = qmul(q0[kq], q0[kq + 1], q0[kq + 2], q0[kq + 3], dx, dy, dz, dw)
    nrm = np.sqrt(x * x + y * y + z * z + w * w)
    q[kq], q[kq + 1], q[kq + 2], q[kq + 3] = x / nrm, y / nrm, z / nrm, w / nrm


@inline_kernel
def _joint_retract(tree, i, q0, delta, q):
    """Joint i's part of q = q0 (+) delta: q0 + delta for 1-dof joints; p0 + delta_p and quat0 (x)
    exp(delta_theta), renormalised, for the free joint (the quaternion part alone for the spherical joint);
    p0 + delta_p and theta0 + delta_theta for the planar joint."""
    k, kq, code = tree.v_idx[i], tree.q_idx[i], tree.jtype[i]
    if code == JOINT_REVOLUTE or code == JOINT_PRISMATIC:
        q[kq] = q0[kq] + delta[k]
        return
    if code == JOINT_SPHERICAL:
        _retract_quaternion(q0, kq, delta[k], delta[k + 1], delta[k + 2], q)
        return
    if code == JOINT_PLANAR:
        q[kq], q[kq + 1] = q0[kq] + delta[k], q0[kq + 1] + delta[k + 1]
        c0, s0 = _unit2(q0, kq + 2)
        cd, sd = np.cos(delta[k + 2]), np.sin(delta[k + 2])
        c, s = c0 * cd - s0 * sd, s0 * cd + c0 * sd
        nrm = np.sqrt(c * c + s * s)
        q[kq + 2], q[kq + 3] = c / nrm, s / nrm
        return
    for r in range(3):
        q[kq + r] = q0[kq + r] + delta[k + r]
    _retract_quaternion(q0, kq + 3, delta[k + 3], delta[k + 4], delta[k + 5], q)


@inline_kernel
def _chart_rate_rotation(delta, k, v, kv, out):
    """out[k:k + 3] = Jr(delta_theta)^-1 omega, delta_theta = delta[k:k + 3], omega = v[kv:kv + 3]."""
    t0, t1, t2 = delta[k], delta[k + 1], delta[k + 2]
    c = _so3_jr_inv(t0, t1, t2)
    out[k], out[k + 1], out[k + 2] = skew_poly(0.5, c, t0, t1, t2, v[kv], v[kv + 1], v[kv + 2])


@inline_kernel
def _joint_chart_rate(tree, i, q, delta, v, out):
    """Joint i's part of d(delta)/dt: v for 1-dof joints; (R(q) v_lin, Jr(delta_theta)^-1 omega) for the free
    joint, Jr^-1 = 1 + [th]/2 + (1/phi^2 - (1 + cos phi)/(2 phi sin phi)) [th]^2 (the second part alone for the
    spherical joint); (R(theta) (vx, vy), wz) for the planar joint."""
    k, kq, code = tree.v_idx[i], tree.q_idx[i], tree.jtype[i]
    if code == JOINT_REVOLUTE or code == JOINT_PRISMATIC:
        out[k] = v[k]
        return
    if code == JOINT_SPHERICAL:
        _chart_rate_rotation(delta, k, v, k, out)
        return
    if code == JOINT_PLANAR:
        c, s = _unit2(q, kq + 2)
        out[k], out[k + 1], out[k + 2] = c * v[k] - s * v[k + 1], s * v[k] + c * v[k + 1], v[k + 2]
        return
    out[k], out[k + 1], out[k + 2] = qrot(q[kq + 3], q[kq + 4], q[kq + 5], q[kq + 6], v[k], v[k + 1], v[k + 2])
    _chart_rate_rotation(delta, k + 3, v, k + 3, out)


@inline_kernel
def _quaternion_log(q0, q1, k, out, ko):
    """out[ko:ko + 3] = log(quat0^-1 quat1) (the shorter way round), the quaternions at q0[k:], q1[k:]."""
    x, y, z, w = qmul(-q0[k], -q0[k + 1], -q0[k + 2], q0[k + 3], q1[k], q1[k + 1], q1[k + 2], q1[k + 3])
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = np.sqrt(x * x + y * y + z * z)
    ang = 2.0 * np.arctan2(s, w)
    f = 2.0 / w if s < 1e-12 else ang / s
    out[ko], out[ko + 1], out[ko + 2] = f * x, f * y, f * z


@inline_kernel
def _planar_angle(q0, q1, k):
    """theta1 - theta0 in (-pi, pi] from the (cos, sin) pairs at q0[k:], q1[k:]."""
    c0, s0, c1, s1 = q0[k], q0[k + 1], q1[k], q1[k + 1]
    return np.arctan2(c0 * s1 - s0 * c1, c0 * c1 + s0 * s1)


@inline_kernel
def _joint_difference(tree, i, q0, q1, out):
    """Joint i's part of the chart tangent d with _retract(q0, d) == q1: q1 - q0 for 1-dof joints,
    (p1 - p0, log(quat0^-1 quat1)) for the free joint (the second part alone for the spherical joint),
    (p1 - p0, theta1 - theta0) for the planar joint."""
    k, kq, code = tree.v_idx[i], tree.q_idx[i], tree.jtype[i]
    if code == JOINT_REVOLUTE or code == JOINT_PRISMATIC:
        out[k] = q1[kq] - q0[kq]
        return
    if code == JOINT_SPHERICAL:
        _quaternion_log(q0, q1, kq, out, k)
        return
    if code == JOINT_PLANAR:
        out[k], out[k + 1], out[k + 2] = q1[kq] - q0[kq], q1[kq + 1] - q0[kq + 1], _planar_angle(q0, q1, kq + 2)
        return
    for r in range(3):
        out[k + r] = q1[kq + r] - q0[kq + r]
    _quaternion_log(q0, q1, kq + 3, out, k + 3)


@inline_kernel
def _joint_log(tree, i, q0, q1, out):
    """Joint i's part of the tangent d with integrate(q0, d) == q1 (Pinocchio's ``difference``): the chart's
    for 1-dof and spherical joints; log6(M0^-1 M1) for the free joint, (V(theta)^-1 R0^T (p1 - p0), theta);
    the SE(2) log for the planar joint, ([[a, b], [-b, a]] R0^T (p1 - p0), theta), a = (theta/2) cot(theta/2),
    b = theta/2."""
    code = tree.jtype[i]
    if code != JOINT_FREE and code != JOINT_PLANAR:
        _joint_difference(tree, i, q0, q1, out)
        return
    k, kq = tree.v_idx[i], tree.q_idx[i]
    d0, d1, d2 = q1[kq] - q0[kq], q1[kq + 1] - q0[kq + 1], q1[kq + 2] - q0[kq + 2]
    if code == JOINT_PLANAR:
        t = _planar_angle(q0, q1, kq + 2)
        c, s = _unit2(q0, kq + 2)
        x, y = c * d0 + s * d1, -s * d0 + c * d1
        a = 1.0 - t * t / 12.0 if abs(t) < 1e-4 else 0.5 * t * np.sin(t) / (1.0 - np.cos(t))
        b = 0.5 * t
        out[k], out[k + 1], out[k + 2] = a * x + b * y, -b * x + a * y, t
        return
    _quaternion_log(q0, q1, kq + 3, out, k + 3)
    t0, t1, t2 = out[k + 3], out[k + 4], out[k + 5]
    nrm = np.sqrt(quaternion_sq(q0, kq + 3))
    x0, x1, x2 = qrot(-q0[kq + 3] / nrm, -q0[kq + 4] / nrm, -q0[kq + 5] / nrm, q0[kq + 6] / nrm, d0, d1, d2)
    out[k], out[k + 1], out[k + 2] = skew_poly(-0.5, _so3_jr_inv(t0, t1, t2), t0, t1, t2, x0, x1, x2)
