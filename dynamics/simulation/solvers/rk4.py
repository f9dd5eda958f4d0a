"""The classical fourth-order Runge-Kutta method, fixed step ([HNW] sec. II.1, the "3/8"-free original):

    k1 = f(t, z),  k2 = f(t + h/2, z + h/2 k1),  k3 = f(t + h/2, z + h/2 k2),  k4 = f(t + h, z + h k3)
    z+ = z + h/6 (k1 + 2 k2 + 2 k3 + k4)

k1 is the slope at the end of the previous step (re-expressed in the new chart), so a step costs 3
evaluations here plus the end slope the fixed-step driver takes: 4.  Samples between steps come from the
cubic Hermite interpolant of (z, f) at both ends.
"""

from typing import NamedTuple

import numpy as np

from ..._numba import generic_inline, kernel
from .interface import problem_rhs

ORDER = 4
STABILITY_LIMIT = 2.785  # |h lambda| on the negative real axis
C = (0.0, 0.5, 0.5, 1.0)


class RK4(NamedTuple):
    K: np.ndarray  # (3, n) stages 2-4
    zs: np.ndarray  # (n,) stage state


@kernel
def make(n):
    return RK4(np.empty((3, n)), np.empty(n))


@generic_inline
def step(m, p, t, h, z, f0, st):
    K, zs = m.K, m.zs
    n = z.shape[0]
    for s in range(3):
        prev = f0 if s == 0 else K[s - 1]
        for r in range(n):
            zs[r] = z[r] + C[s + 1] * h * prev[r]
        problem_rhs(p, t + C[s + 1] * h, zs, K[s])
    st.rhs_evals += 3
    for r in range(n):
        z[r] += h / 6.0 * (f0[r] + 2.0 * K[0, r] + 2.0 * K[1, r] + K[2, r])


@kernel
def fixed_dense(m, x, h, z0, f0, z1, f1, out):
    """Cubic Hermite through (z0, f0) and (z1, f1)."""
    h00 = (1 + 2 * x) * (1 - x) ** 2
    h10 = x * (1 - x) ** 2
    h01 = x * x * (3 - 2 * x)
    h11 = x * x * (x - 1)
    for r in range(out.shape[0]):
        out[r] = h00 * z0[r] + h10 * h * f0[r] + h01 * z1[r] + h11 * h * f1[r]


RK4.step = step
RK4.fixed_dense = fixed_dense
