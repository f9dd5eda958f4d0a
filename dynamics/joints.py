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

import numpy as np
from ._numba import inline_kernel

from .spatial import add, load3, load33, matmul, quat_rotation, rot, scale

JOINT_REVOLUTE = 0
JOINT_PRISMATIC = 1
JOINT_FREE = 2

#: nq and nv of each joint code
JOINT_NQ = {JOINT_REVOLUTE: 1, JOINT_PRISMATIC: 1, JOINT_FREE: 7}
JOINT_NV = {JOINT_REVOLUTE: 1, JOINT_PRISMATIC: 1, JOINT_FREE: 6}

#: URDF joint type -> kernel code
URDF_JOINT_CODES = {
    "revolute": JOINT_REVOLUTE,
    "continuous": JOINT_REVOLUTE,
    "prismatic": JOINT_PRISMATIC,
    "floating": JOINT_FREE,
}


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
def joint_transform(tree, i, q):
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
    R = matmul(X, quat_rotation(q[k + 3], q[k + 4], q[k + 5], q[k + 6]))
    return R, add(p0, rot(X, (q[k], q[k + 1], q[k + 2])))


@inline_kernel
def joint_motion(tree, i, qd):
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
def project_force(tree, i, n, f, tau):
    """tau[dofs of i] = S_i^T (n, f): the generalised force the joint transmits."""
    S = tree.S
    for k in range(tree.v_idx[i], tree.v_idx[i] + tree.nv_j[i]):
        tau[k] = (S[k, 0] * n[0] + S[k, 1] * n[1] + S[k, 2] * n[2]
                  + S[k, 3] * f[0] + S[k, 4] * f[1] + S[k, 5] * f[2])
