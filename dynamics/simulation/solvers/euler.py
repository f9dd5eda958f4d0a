"""Semi-implicit (symplectic) Euler, first order, fixed step: v+ = v + h a(q, v), then q+ = q (+) h v+
(the configuration moves with the *new* velocity, which keeps the energy of conservative systems bounded);
the quadratures by explicit Euler.  Samples between steps: linear interpolation.
"""

from typing import NamedTuple

import numpy as np

from ..._numba import generic_inline, kernel
from .interface import problem_euler_config

ORDER = 1
STABILITY_LIMIT = 2.0  # |h lambda| on the negative real axis


class Euler(NamedTuple):
    """No workspace: one right-hand side per step (the slope at its start, f0)."""

    nc: int  # configuration components of z


@generic_inline
def step(m, p, t, h, z, f0, st):
    for r in range(m.nc, z.shape[0]):
        z[r] += h * f0[r]
    problem_euler_config(p, z, h)


@kernel
def fixed_dense(m, x, h, z0, f0, z1, f1, out):
    for r in range(out.shape[0]):
        out[r] = z0[r] + x * (z1[r] - z0[r])


Euler.step = step
Euler.fixed_dense = fixed_dense
