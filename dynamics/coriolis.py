"""A Coriolis matrix C(q, v) with C v = bias_forces - g(q) and dM/dt - 2C skew-symmetric.

C is not unique; this is the factorisation of Echeandia & Wensing (2021, "A numerical method for computing
the Coriolis matrix", eq. 28), written in body coordinates:

    C = sum_i J_i^T [ I_i dJ_i + 1/2 ( v_i x* I_i + I_i v_i x + (I_i v_i) xbar ) J_i ]

where J_i is body i's Jacobian in its own frame, dJ_i its time derivative and (f xbar) v = v x* f.  Its
skew-symmetry follows from dM/dt = sum (dJ^T I J + J^T I dJ) because v x* I + I v x and (I v) xbar are both
skew.  Recursion for the Jacobian columns of the ancestors of i (parent p, joint velocity v_J = S_i qd_i):

    J_i = X_i J_p (+ S_i on i's own columns),   dJ_i = X_i dJ_p - v_J x (X_i J_p)   (own columns: 0).

Cost is O(n d^2) for depth d: it is meant for analysis and control design, not for inner loops.

The algorithm is the core's (``core/coriolis.cpp``); this module checks the arguments and calls it.
"""

import numpy as np

from . import _core, checks
from .parallel import run


def coriolis_matrix(model, q, v):
    """C(q, v), (nv, nv) or (B, nv, nv): C v + g(q) = bias_forces(q, v), dM/dt - 2C skew-symmetric."""
    checks.check_model(model)
    Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = run(_core.coriolis_batch, model, Q, V, out=np.empty((B, model.nv, model.nv)))
    return out if batched else out[0]
