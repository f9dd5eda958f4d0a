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

