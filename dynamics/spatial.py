"""Spatial algebra in one place (Featherstone, *Rigid Body Dynamics Algorithms*, 2008, ch. 2).

Conventions used by every kernel:

* A spatial motion vector is kept as two 3-vectors ``(w, v)``: angular velocity and the linear velocity of
  the point at the frame origin, both in the frame's coordinates (Featherstone's order, angular first).
* A spatial force is ``(n, f)``: moment about the frame origin and force, same coordinates.
* A transform from a child frame B to its parent P is ``(R, p)``: ``R`` = P_R_B (columns are B's axes in P)
  and ``p`` = B's origin in P.  Motion P -> B: ``w_B = R^T w_P``, ``v_B = R^T (v_P + w_P x p)``.
  Force B -> P: ``f_P = R f_B``, ``n_P = R n_B + p x (R f_B)`` (eq. 2.24-2.25 with X* = X^-T).
* A rigid-body inertia about the frame origin is ``(m, h, Io)``: mass, first moment ``h = m c`` and the
  rotational inertia about the origin ``Io = Ic + m [c]x^T [c]x``.  Its 6x6 form (angular first) is
  ``[[Io, [h]x], [[h]x^T, m 1]]`` (eq. 2.63).

3-vectors are tuples ``(x, y, z)`` and 3x3 matrices row-major 9-tuples, so that the kernels pass values in
registers: slicing a row out of a numba array makes a reference-counted view, which costs more than the
arithmetic here.  ``load3``/``store3`` move them between tuples and rows of the model's flat arrays.

The algebra is :data:`~dynamics._numba.helper` (numba's ``register_jitable``): compiled into each kernel that
calls it, with no entry point or cache file of its own; called from Python it runs as plain Python.  The
rotations Python code also uses (``_rotation_about_axis``, ``_quat_rotation``, ``_rotation_log``) are kernels.
"""

import numpy as np

from ._numba import helper, inline_kernel, kernel
# -- moving values between arrays and tuples -------------------------------------------------------

@helper
def load3(A, i):
    return (A[i, 0], A[i, 1], A[i, 2])


@helper
def store3(A, i, x):
    A[i, 0] = x[0]
    A[i, 1] = x[1]
    A[i, 2] = x[2]


@helper
def load33(A, i):
    return (A[i, 0, 0], A[i, 0, 1], A[i, 0, 2], A[i, 1, 0], A[i, 1, 1], A[i, 1, 2], A[i, 2, 0], A[i, 2, 1],
            A[i, 2, 2])


@helper
def store33(A, i, M):
    for r in range(3):
        for c in range(3):
            A[i, r, c] = M[3 * r + c]


# -- 3-vectors and 3x3 matrices ------------------------------------------------------------------------

@helper
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@helper
def scale(s, a):
    return (s * a[0], s * a[1], s * a[2])


@helper
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@helper
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@helper
def rot(R, x):
    """R x."""
    return (R[0] * x[0] + R[1] * x[1] + R[2] * x[2],
            R[3] * x[0] + R[4] * x[1] + R[5] * x[2],
            R[6] * x[0] + R[7] * x[1] + R[8] * x[2])


@helper
def rotT(R, x):
    """R^T x."""
    return (R[0] * x[0] + R[3] * x[1] + R[6] * x[2],
            R[1] * x[0] + R[4] * x[1] + R[7] * x[2],
            R[2] * x[0] + R[5] * x[1] + R[8] * x[2])


@helper
def matmul(A, B):
    """A B for 3x3 matrices."""
    return (A[0] * B[0] + A[1] * B[3] + A[2] * B[6], A[0] * B[1] + A[1] * B[4] + A[2] * B[7],
            A[0] * B[2] + A[1] * B[5] + A[2] * B[8],
            A[3] * B[0] + A[4] * B[3] + A[5] * B[6], A[3] * B[1] + A[4] * B[4] + A[5] * B[7],
            A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
            A[6] * B[0] + A[7] * B[3] + A[8] * B[6], A[6] * B[1] + A[7] * B[4] + A[8] * B[7],
            A[6] * B[2] + A[7] * B[5] + A[8] * B[8])


@helper
def transpose(A):
    return (A[0], A[3], A[6], A[1], A[4], A[7], A[2], A[5], A[8])


@helper
def rot_congruence(R, X):
    """R X R^T."""
    return matmul(matmul(R, X), transpose(R))


# -- spatial operations --------------------------------------------------------------------------------

@helper
def motion_to_child(R, p, w, v):
    """X (w, v): the parent's motion vector in the child frame."""
    return rotT(R, w), rotT(R, add(v, cross(w, p)))


@helper
def force_to_parent(R, p, n, f):
    """X^T (n, f): the child's force in the parent frame."""
    fP = rot(R, f)
    return add(rot(R, n), cross(p, fP)), fP


@helper
def inertia_times(m, h, Io, w, v):
    """I (w, v) = (Io w + h x v, m v - h x w) for the rigid-body inertia (m, h, Io)."""
    n = add(rot(Io, w), cross(h, v))
    hw = cross(h, w)
    return n, (m * v[0] - hw[0], m * v[1] - hw[1], m * v[2] - hw[2])


@helper
def cross_motion(w, v, wJ, vJ):
    """(w, v) x (wJ, vJ) = (w x wJ, w x vJ + v x wJ)   (eq. 2.31)."""
    return cross(w, wJ), add(cross(w, vJ), cross(v, wJ))


@helper
def cross_force(w, v, n, f):
    """(w, v) x* (n, f) = (w x n + v x f, w x f)   (eq. 2.32)."""
    return add(cross(w, n), cross(v, f)), cross(w, f)


@helper
def motion_to_parent(R, p, w, v):
    """X^-1 (w, v): the child's motion vector in the parent frame, (R w, R v + p x R w) (Pinocchio's act)."""
    wP = rot(R, w)
    return wP, add(rot(R, v), cross(p, wP))


@helper
def get6(A, k):
    """Row k of an (n, 6) array as a pair of 3-tuples (angular/moment first)."""
    return (A[k, 0], A[k, 1], A[k, 2]), (A[k, 3], A[k, 4], A[k, 5])


@helper
def set6(A, k, x, y):
    A[k, 0], A[k, 1], A[k, 2] = x
    A[k, 3], A[k, 4], A[k, 5] = y


@helper
def dot6(aw, av, bw, bv):
    """The pairing of a motion and a force (or two 6-vectors), a . b."""
    return aw[0] * bw[0] + aw[1] * bw[1] + aw[2] * bw[2] + av[0] * bv[0] + av[1] * bv[1] + av[2] * bv[2]


@helper
def inertia_to_parent(R, p, m, h, Io):
    """The rigid-body inertia (m, h, Io) of a child frame, expressed about the parent's origin: (h', Io').

    With r' = R r + p for every mass point: h' = R h + m p and
    Io' = R Io R^T + (2 p.(R h) + m |p|^2) 1 - ((R h) p^T + p (R h)^T + m p p^T).
    """
    hR = rot(R, h)
    A = rot_congruence(R, Io)
    d = 2.0 * dot(p, hR) + m * dot(p, p)
    out = (A[0] + d - 2.0 * hR[0] * p[0] - m * p[0] * p[0],
           A[1] - hR[0] * p[1] - p[0] * hR[1] - m * p[0] * p[1],
           A[2] - hR[0] * p[2] - p[0] * hR[2] - m * p[0] * p[2],
           A[3] - hR[1] * p[0] - p[1] * hR[0] - m * p[1] * p[0],
           A[4] + d - 2.0 * hR[1] * p[1] - m * p[1] * p[1],
           A[5] - hR[1] * p[2] - p[1] * hR[2] - m * p[1] * p[2],
           A[6] - hR[2] * p[0] - p[2] * hR[0] - m * p[2] * p[0],
           A[7] - hR[2] * p[1] - p[2] * hR[1] - m * p[2] * p[1],
           A[8] + d - 2.0 * hR[2] * p[2] - m * p[2] * p[2])
    return add(hR, scale(m, p)), out


@helper
def _block(I, r0, c0):
    return (I[r0, c0], I[r0, c0 + 1], I[r0, c0 + 2], I[r0 + 1, c0], I[r0 + 1, c0 + 1], I[r0 + 1, c0 + 2],
            I[r0 + 2, c0], I[r0 + 2, c0 + 1], I[r0 + 2, c0 + 2])


@inline_kernel
def _add_inertia6_to_parent(R, p, I, IA, par):
    """IA[par] += X^T I X for a 6x6 (articulated) inertia I given in the child frame.

    With I = [[A, B], [B^T, C]], A' = R A R^T, B' = R B R^T, C' = R C R^T and P = [p]x:
    X^T I X = [[A' - B'P - (B'P)^T - P C'P,  B' - (C'P)^T], [B'^T - C'P, C']].
    """
    A = rot_congruence(R, _block(I, 0, 0))
    B = rot_congruence(R, _block(I, 0, 3))
    C = rot_congruence(R, _block(I, 3, 3))
    P = (0.0, -p[2], p[1], p[2], 0.0, -p[0], -p[1], p[0], 0.0)
    CP = matmul(C, P)
    BP = matmul(B, P)
    PCP = matmul(P, CP)
    for r in range(3):
        for c in range(3):
            IA[par, r, c] += A[3 * r + c] - BP[3 * r + c] - BP[3 * c + r] - PCP[3 * r + c]
            t = B[3 * r + c] - CP[3 * c + r]
            IA[par, r, 3 + c] += t
            IA[par, 3 + c, r] += t
            IA[par, 3 + r, 3 + c] += C[3 * r + c]


@inline_kernel
def _store_inertia6(I, i, m, h, Io):
    """I[i] = the 6x6 rigid-body inertia [[Io, [h]x], [[h]x^T, m 1]] (angular first, eq. 2.63)."""
    for r in range(3):
        for c in range(3):
            I[i, r, c] = Io[3 * r + c]
            I[i, 3 + r, 3 + c] = m if r == c else 0.0
    I[i, 0, 3], I[i, 0, 4], I[i, 0, 5] = 0.0, -h[2], h[1]
    I[i, 1, 3], I[i, 1, 4], I[i, 1, 5] = h[2], 0.0, -h[0]
    I[i, 2, 3], I[i, 2, 4], I[i, 2, 5] = -h[1], h[0], 0.0
    for r in range(3):
        for c in range(3):
            I[i, 3 + c, r] = I[i, r, 3 + c]


@inline_kernel
def _joint_gram(S, U, k0, nj, D):
    """D[:nj, :nj] = S^T U over a joint's rows k0 .. k0 + nj of S and U (6-vectors per row): D_i = S_i^T I^A S_i."""
    for a in range(nj):
        for b in range(nj):
            x = 0.0
            for r in range(6):
                x += S[k0 + a, r] * U[k0 + b, r]
            D[a, b] = x


@helper
def qmul(ax, ay, az, aw, bx, by, bz, bw):
    """Hamilton product a * b of quaternions (x, y, z, w)."""
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


@helper
def qexp(w0, w1, w2):
    """Unit quaternion of the rotation vector w (exp map), accurate near zero."""
    th2 = w0 * w0 + w1 * w1 + w2 * w2
    if th2 < 1e-12:
        s = 0.5 - th2 / 48.0  # sin(th/2)/th by its Taylor series
        c = 1.0 - th2 / 8.0
    else:
        th = np.sqrt(th2)
        s = np.sin(0.5 * th) / th
        c = np.cos(0.5 * th)
    return s * w0, s * w1, s * w2, c


@helper
def qrot(x, y, z, w, a0, a1, a2):
    """R(quat) a for a unit quaternion (x, y, z, w)."""
    # a + 2 w (u x a) + 2 u x (u x a), u = (x, y, z)
    c0 = y * a2 - z * a1
    c1 = z * a0 - x * a2
    c2 = x * a1 - y * a0
    return (a0 + 2.0 * (w * c0 + y * c2 - z * c1),
            a1 + 2.0 * (w * c1 + z * c0 - x * c2),
            a2 + 2.0 * (w * c2 + x * c1 - y * c0))


@helper
def quaternion_sq(q, k):
    """Squared norm of the quaternion q[k:k + 4]."""
    return q[k] * q[k] + q[k + 1] * q[k + 1] + q[k + 2] * q[k + 2] + q[k + 3] * q[k + 3]


@helper
def skew_poly(a, b, t0, t1, t2, x0, x1, x2):
    """(1 + a [t] + b [t]^2) x."""
    c0 = t1 * x2 - t2 * x1
    c1 = t2 * x0 - t0 * x2
    c2 = t0 * x1 - t1 * x0
    d0 = t1 * c2 - t2 * c1
    d1 = t2 * c0 - t0 * c2
    d2 = t0 * c1 - t1 * c0
    return x0 + a * c0 + b * d0, x1 + a * c1 + b * d1, x2 + a * c2 + b * d2


@kernel
def _rotation_about_axis(axis, angle):
    """Rodrigues' formula: exp([axis]x angle) for a unit axis, as a 9-tuple."""
    c = np.cos(angle)
    s = np.sin(angle)
    t = 1.0 - c
    x, y, z = axis
    return (t * x * x + c, t * x * y - s * z, t * x * z + s * y,
            t * x * y + s * z, t * y * y + c, t * y * z - s * x,
            t * x * z - s * y, t * y * z + s * x, t * z * z + c)


@kernel
def _quat_rotation(qx, qy, qz, qw):
    """Rotation matrix (9-tuple) of the quaternion (qx, qy, qz, qw), normalised first (Hamilton)."""
    nrm = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / nrm, qy / nrm, qz / nrm, qw / nrm
    return (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w),
            2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w),
            2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y))


@kernel
def _rotation_log(R):
    """The rotation vector theta * axis of R (9-tuple), log: SO(3) -> R^3, accurate near 0 and near pi."""
    w = (0.5 * (R[7] - R[5]), 0.5 * (R[2] - R[6]), 0.5 * (R[3] - R[1]))  # sin(theta) axis
    c = min(1.0, max(-1.0, 0.5 * (R[0] + R[4] + R[8] - 1.0)))  # cos(theta)
    s = np.sqrt(dot(w, w))
    theta = np.arctan2(s, c)
    if c > -0.99:  # theta / sin(theta) is well conditioned (series near 0)
        f = 1.0 + s * s / 6.0 if s < 1e-8 else theta / s
        return scale(f, w)
    # near pi: the axis from R + R^T = 2 c 1 + 2 (1 - c) a a^T, its largest diagonal entry first
    k = 0
    if R[4] > R[3 * k + k]:
        k = 1
    if R[8] > R[3 * k + k]:
        k = 2
    a = ((R[k] + R[3 * k]) * 0.5, (R[3 + k] + R[3 * k + 1]) * 0.5, (R[6 + k] + R[3 * k + 2]) * 0.5)
    a = (a[0] - (c if k == 0 else 0.0), a[1] - (c if k == 1 else 0.0), a[2] - (c if k == 2 else 0.0))
    n = np.sqrt(dot(a, a))
    if dot(a, w) < 0.0:
        n = -n
    return scale(theta / n, a)


@inline_kernel
def _spd_inverse(D, n, Dinv, i, A):
    """Dinv[i, :n, :n] = inverse of the symmetric positive definite D[:n, :n] (Gauss-Jordan without
    pivoting, valid for SPD; A is (6, 6) scratch).  Returns False when a pivot is not positive."""
    for r in range(n):
        for c in range(n):
            A[r, c] = D[r, c]
            Dinv[i, r, c] = 1.0 if r == c else 0.0
    for k in range(n):
        piv = A[k, k]
        if not piv > 0.0:
            return False
        inv = 1.0 / piv
        for c in range(n):
            A[k, c] *= inv
            Dinv[i, k, c] *= inv
        for r in range(n):
            if r != k:
                fac = A[r, k]
                if fac != 0.0:
                    for c in range(n):
                        A[r, c] -= fac * A[k, c]
                        Dinv[i, r, c] -= fac * Dinv[i, k, c]
    return True


def rpy_to_matrix(rpy):
    """URDF roll-pitch-yaw to a rotation matrix: R = Rz(yaw) Ry(pitch) Rx(roll) (plain numpy, load time).  Each
    entry's products are grouped as in trimesh's ``euler_matrix(.., 'sxyz')``, which the URDF reader used before
    it read origins itself, so models keep their bits (Pinocchio's quaternion route is within 8e-16 of it)."""
    r, p, y = rpy
    sr, sp, sy = np.sin(r), np.sin(p), np.sin(y)
    cr, cp, cy = np.cos(r), np.cos(p), np.cos(y)
    return np.array([
        [cp * cy, sp * (sr * cy) - cr * sy, sp * (cr * cy) + sr * sy],
        [cp * sy, sp * (sr * sy) + cr * cy, sp * (cr * sy) - sr * cy],
        [-sp, cp * sr, cp * cr],
    ])
