"""Interpolation of the torque sources' references: the segment of a time table, and quintic Hermite
interpolation of [position, velocity, acceleration] samples (C2, and consistent: v = q', a = v')."""

import numpy as np

from .._numba import kernel


@kernel
def segment(times, t):
    """k with times[k] <= t < times[k+1], clipped to [0, N-2] (N >= 2)."""
    k = np.searchsorted(times, t, side="right") - 1
    if k < 0:
        k = 0
    if k > times.shape[0] - 2:
        k = times.shape[0] - 2
    return k


@kernel
def reference_at(times, table, nv, t, q, v, a):
    """Quintic Hermite interpolation of the reference [q, v, a] rows of ``table`` at time t (clamped)."""
    N = times.shape[0]
    if N == 1 or t <= times[0] or t >= times[N - 1]:
        k = 0 if (N == 1 or t <= times[0]) else N - 1
        for i in range(nv):
            q[i] = table[k, i]
            v[i] = table[k, nv + i]
            a[i] = table[k, 2 * nv + i]
        return
    k = segment(times, t)
    h = times[k + 1] - times[k]
    s = (t - times[k]) / h
    s2 = s * s
    s3 = s2 * s
    s4 = s3 * s
    s5 = s4 * s
    H = (1 - 10 * s3 + 15 * s4 - 6 * s5, s - 6 * s3 + 8 * s4 - 3 * s5, 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5,
         0.5 * s3 - s4 + 0.5 * s5, -4 * s3 + 7 * s4 - 3 * s5, 10 * s3 - 15 * s4 + 6 * s5)
    D = (-30 * s2 + 60 * s3 - 30 * s4, 1 - 18 * s2 + 32 * s3 - 15 * s4, s - 4.5 * s2 + 6 * s3 - 2.5 * s4,
         1.5 * s2 - 4 * s3 + 2.5 * s4, -12 * s2 + 28 * s3 - 15 * s4, 30 * s2 - 60 * s3 + 30 * s4)
    DD = (-60 * s + 180 * s2 - 120 * s3, -36 * s + 96 * s2 - 60 * s3, 1 - 9 * s + 18 * s2 - 10 * s3,
          3 * s - 12 * s2 + 10 * s3, -24 * s + 84 * s2 - 60 * s3, 60 * s - 180 * s2 + 120 * s3)
    for i in range(nv):
        c0 = table[k, i]
        c1 = h * table[k, nv + i]
        c2 = h * h * table[k, 2 * nv + i]
        c3 = h * h * table[k + 1, 2 * nv + i]
        c4 = h * table[k + 1, nv + i]
        c5 = table[k + 1, i]
        q[i] = H[0] * c0 + H[1] * c1 + H[2] * c2 + H[3] * c3 + H[4] * c4 + H[5] * c5
        v[i] = (D[0] * c0 + D[1] * c1 + D[2] * c2 + D[3] * c3 + D[4] * c4 + D[5] * c5) / h
        a[i] = (DD[0] * c0 + DD[1] * c1 + DD[2] * c2 + DD[3] * c3 + DD[4] * c4 + DD[5] * c5) / (h * h)
