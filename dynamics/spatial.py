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

Everything here is ``numba.njit`` and allocation free: results are written into ``out`` arguments.
"""

import numpy as np
from numba import njit

_JIT = dict(cache=True, nogil=True)


@njit(**_JIT)
def cross(a, b, out):
    """out = a x b (out must not alias a or b)."""
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(**_JIT)
def add_cross(a, b, out):
    """out += a x b."""
    out[0] += a[1] * b[2] - a[2] * b[1]
    out[1] += a[2] * b[0] - a[0] * b[2]
    out[2] += a[0] * b[1] - a[1] * b[0]


@njit(**_JIT)
def matvec(R, x, out):
    """out = R x."""
    for r in range(3):
        out[r] = R[r, 0] * x[0] + R[r, 1] * x[1] + R[r, 2] * x[2]


@njit(**_JIT)
def matTvec(R, x, out):
    """out = R^T x."""
    for r in range(3):
        out[r] = R[0, r] * x[0] + R[1, r] * x[1] + R[2, r] * x[2]


@njit(**_JIT)
def matmul3(A, B, out):
    """out = A B for 3x3 matrices."""
    for r in range(3):
        for c in range(3):
            out[r, c] = A[r, 0] * B[0, c] + A[r, 1] * B[1, c] + A[r, 2] * B[2, c]


@njit(**_JIT)
def motion_to_child(R, p, wP, vP, wB, vB):
    """Express the parent's spatial motion (wP, vP) in the child frame: (wB, vB) = X (wP, vP)."""
    t0 = vP[0] + wP[1] * p[2] - wP[2] * p[1]
    t1 = vP[1] + wP[2] * p[0] - wP[0] * p[2]
    t2 = vP[2] + wP[0] * p[1] - wP[1] * p[0]
    for r in range(3):
        wB[r] = R[0, r] * wP[0] + R[1, r] * wP[1] + R[2, r] * wP[2]
        vB[r] = R[0, r] * t0 + R[1, r] * t1 + R[2, r] * t2


@njit(**_JIT)
def add_force_to_parent(R, p, nB, fB, nP, fP):
    """Accumulate the child's spatial force (nB, fB) into the parent's (nP, fP): (nP, fP) += X^T (nB, fB)."""
    f0 = R[0, 0] * fB[0] + R[0, 1] * fB[1] + R[0, 2] * fB[2]
    f1 = R[1, 0] * fB[0] + R[1, 1] * fB[1] + R[1, 2] * fB[2]
    f2 = R[2, 0] * fB[0] + R[2, 1] * fB[1] + R[2, 2] * fB[2]
    for r in range(3):
        nP[r] += R[r, 0] * nB[0] + R[r, 1] * nB[1] + R[r, 2] * nB[2]
    nP[0] += p[1] * f2 - p[2] * f1
    nP[1] += p[2] * f0 - p[0] * f2
    nP[2] += p[0] * f1 - p[1] * f0
    fP[0] += f0
    fP[1] += f1
    fP[2] += f2


@njit(**_JIT)
def inertia_times_motion(m, h, Io, w, v, n, f):
    """(n, f) = I (w, v) for the rigid-body inertia (m, h, Io): n = Io w + h x v, f = m v - h x w."""
    for r in range(3):
        n[r] = Io[r, 0] * w[0] + Io[r, 1] * w[1] + Io[r, 2] * w[2]
    n[0] += h[1] * v[2] - h[2] * v[1]
    n[1] += h[2] * v[0] - h[0] * v[2]
    n[2] += h[0] * v[1] - h[1] * v[0]
    f[0] = m * v[0] - (h[1] * w[2] - h[2] * w[1])
    f[1] = m * v[1] - (h[2] * w[0] - h[0] * w[2])
    f[2] = m * v[2] - (h[0] * w[1] - h[1] * w[0])


@njit(**_JIT)
def add_cross_force(w, v, n, f, nout, fout):
    """(nout, fout) += (w, v) x* (n, f) = (w x n + v x f, w x f)   (eq. 2.32)."""
    add_cross(w, n, nout)
    add_cross(v, f, nout)
    add_cross(w, f, fout)


@njit(**_JIT)
def add_cross_motion(w, v, wJ, vJ, wout, vout):
    """(wout, vout) += (w, v) x (wJ, vJ) = (w x wJ, w x vJ + v x wJ)   (eq. 2.31)."""
    add_cross(w, wJ, wout)
    add_cross(w, vJ, vout)
    add_cross(v, wJ, vout)


@njit(**_JIT)
def inertia_to_parent(R, p, m, h, Io, hP, IoP):
    """Accumulate a rigid-body inertia (m, h, Io) given in a child frame into the parent's (hP, IoP).

    With r' = R r + p for every mass point: h' = R h + m p and
    Io' = R Io R^T + (2 p.(R h) + m |p|^2) 1 - ((R h) p^T + p (R h)^T + m p p^T).
    """
    hR0 = R[0, 0] * h[0] + R[0, 1] * h[1] + R[0, 2] * h[2]
    hR1 = R[1, 0] * h[0] + R[1, 1] * h[1] + R[1, 2] * h[2]
    hR2 = R[2, 0] * h[0] + R[2, 1] * h[1] + R[2, 2] * h[2]
    hP[0] += hR0 + m * p[0]
    hP[1] += hR1 + m * p[1]
    hP[2] += hR2 + m * p[2]
    # R Io R^T
    for r in range(3):
        t0 = R[r, 0] * Io[0, 0] + R[r, 1] * Io[1, 0] + R[r, 2] * Io[2, 0]
        t1 = R[r, 0] * Io[0, 1] + R[r, 1] * Io[1, 1] + R[r, 2] * Io[2, 1]
        t2 = R[r, 0] * Io[0, 2] + R[r, 1] * Io[1, 2] + R[r, 2] * Io[2, 2]
        for c in range(3):
            IoP[r, c] += t0 * R[c, 0] + t1 * R[c, 1] + t2 * R[c, 2]
    d = 2.0 * (p[0] * hR0 + p[1] * hR1 + p[2] * hR2) + m * (p[0] * p[0] + p[1] * p[1] + p[2] * p[2])
    hR = (hR0, hR1, hR2)
    for r in range(3):
        IoP[r, r] += d
        for c in range(3):
            IoP[r, c] -= hR[r] * p[c] + p[r] * hR[c] + m * p[r] * p[c]


@njit(**_JIT)
def rotation_about_axis(axis, angle, out):
    """Rodrigues' formula: out = exp([axis]x angle) for a unit axis."""
    c = np.cos(angle)
    s = np.sin(angle)
    t = 1.0 - c
    x, y, z = axis[0], axis[1], axis[2]
    out[0, 0] = t * x * x + c
    out[0, 1] = t * x * y - s * z
    out[0, 2] = t * x * z + s * y
    out[1, 0] = t * x * y + s * z
    out[1, 1] = t * y * y + c
    out[1, 2] = t * y * z - s * x
    out[2, 0] = t * x * z - s * y
    out[2, 1] = t * y * z + s * x
    out[2, 2] = t * z * z + c


@njit(**_JIT)
def quat_to_rot(qx, qy, qz, qw, out):
    """Rotation matrix of the quaternion (qx, qy, qz, qw), normalised first (Hamilton convention)."""
    nrm = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / nrm, qy / nrm, qz / nrm, qw / nrm
    out[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    out[0, 1] = 2.0 * (x * y - z * w)
    out[0, 2] = 2.0 * (x * z + y * w)
    out[1, 0] = 2.0 * (x * y + z * w)
    out[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    out[1, 2] = 2.0 * (y * z - x * w)
    out[2, 0] = 2.0 * (x * z - y * w)
    out[2, 1] = 2.0 * (y * z + x * w)
    out[2, 2] = 1.0 - 2.0 * (x * x + y * y)


@njit(**_JIT)
def quat_multiply(a, b, out):
    """out = a * b for quaternions stored (x, y, z, w)."""
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    out[0] = aw * bx + ax * bw + ay * bz - az * by
    out[1] = aw * by - ax * bz + ay * bw + az * bx
    out[2] = aw * bz + ax * by - ay * bx + az * bw
    out[3] = aw * bw - ax * bx - ay * by - az * bz


@njit(**_JIT)
def exp_quat(w, out):
    """Unit quaternion (x, y, z, w) of the rotation vector w (exp map of so(3)), accurate near zero."""
    th = np.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    if th < 1e-6:
        s = 0.5 - th * th / 48.0  # sin(th/2)/th by its Taylor series
        c = 1.0 - th * th / 8.0
    else:
        s = np.sin(0.5 * th) / th
        c = np.cos(0.5 * th)
    out[0] = s * w[0]
    out[1] = s * w[1]
    out[2] = s * w[2]
    out[3] = c


def rpy_to_matrix(rpy):
    """URDF roll-pitch-yaw to a rotation matrix: R = Rz(yaw) Ry(pitch) Rx(roll) (plain numpy, load time)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


@njit(**_JIT)
def rot_congruence(R, X, out):
    """out = R X R^T for 3x3 matrices."""
    for r in range(3):
        t0 = R[r, 0] * X[0, 0] + R[r, 1] * X[1, 0] + R[r, 2] * X[2, 0]
        t1 = R[r, 0] * X[0, 1] + R[r, 1] * X[1, 1] + R[r, 2] * X[2, 1]
        t2 = R[r, 0] * X[0, 2] + R[r, 1] * X[1, 2] + R[r, 2] * X[2, 2]
        for c in range(3):
            out[r, c] = t0 * R[c, 0] + t1 * R[c, 1] + t2 * R[c, 2]


@njit(cache=True, nogil=True)
def add_inertia6_to_parent(R, p, I, IP, tmp):
    """IP += X^T I X for a 6x6 (articulated) inertia I in the child frame; tmp is (6, 3, 3) scratch.

    With I = [[A, B], [B^T, C]], A' = R A R^T, B' = R B R^T, C' = R C R^T and P = [p]x:
    X^T I X = [[A' - B'P - (B'P)^T - P C'P,  B' - (C'P)^T], [B'^T - C'P, C']].
    """
    A, Bm, C, P, CP, BP = tmp[0], tmp[1], tmp[2], tmp[3], tmp[4], tmp[5]
    rot_congruence(R, I[0:3, 0:3], A)
    rot_congruence(R, I[0:3, 3:6], Bm)
    rot_congruence(R, I[3:6, 3:6], C)
    P[0, 0], P[0, 1], P[0, 2] = 0.0, -p[2], p[1]
    P[1, 0], P[1, 1], P[1, 2] = p[2], 0.0, -p[0]
    P[2, 0], P[2, 1], P[2, 2] = -p[1], p[0], 0.0
    matmul3(C, P, CP)
    matmul3(Bm, P, BP)
    for r in range(3):
        for c in range(3):
            PCP = P[r, 0] * CP[0, c] + P[r, 1] * CP[1, c] + P[r, 2] * CP[2, c]
            IP[r, c] += A[r, c] - BP[r, c] - BP[c, r] - PCP
            tr = Bm[r, c] - CP[c, r]
            IP[r, 3 + c] += tr
            IP[3 + c, r] += tr
            IP[3 + r, 3 + c] += C[r, c]


@njit(cache=True, nogil=True)
def spd_inverse(D, n, out):
    """out[:n, :n] = inverse of the symmetric positive definite D[:n, :n] (Gauss-Jordan, no pivoting,
    valid for SPD).  Returns False when a pivot is not positive (D singular or indefinite)."""
    for r in range(n):
        for c in range(n):
            out[r, c] = 1.0 if r == c else 0.0
    A = D[:n, :n].copy()
    for k in range(n):
        piv = A[k, k]
        if not piv > 0.0:
            return False
        inv = 1.0 / piv
        for c in range(n):
            A[k, c] *= inv
            out[k, c] *= inv
        for r in range(n):
            if r != k:
                fac = A[r, k]
                if fac != 0.0:
                    for c in range(n):
                        A[r, c] -= fac * A[k, c]
                        out[r, c] -= fac * out[k, c]
    return True
