"""The inverse of the mass matrix, computed directly in O(n^2) by the articulated-body approach (Carpentier &
Mansard, "Analytical derivatives of rigid body dynamics algorithms", RSS 2018; Pinocchio's computeMinverse).

Column c of M^-1 is the ABA's answer (:mod:`dynamics.aba`) to tau = e_c at v = 0 without gravity; all columns
are run at once.  Everything is expressed in the world frame (motion axes S_i = oX_i S_i^body, inertias about
the world origin), so no per-column spatial transform is needed.  F_i (6 x nv, kept as one 6-vector per
column) is the articulated bias force of the subtree of i (the ABA's p^A), nonzero only in the subtree's
columns; A_i (6 x nv, same storage) the acceleration:

    backward (leaves in):  U_i = I^A_i S_i,  D_i = S_i^T U_i,
                           M^-1[i, sub(i)] = D_i^-1 (E_i - S_i^T F_i)           (E_i: the identity at i's dofs)
                           I^A_p += I^A_i - U_i D_i^-1 U_i^T,   F_p += F_i + U_i M^-1[i, sub(i)]

(the children's sub(i) are disjoint, so F_p on sub(i) is simply set from child i, and F_i is zero at i's own
columns, never stored: F needs no clearing)
    forward (root out):    M^-1[i, c] -= (U_i D_i^-1)^T A_p[:, c],   A_i = A_p + S_i M^-1[i, c]   (c >= i)

sub(i) are the velocity coordinates of the subtree of i, contiguous from i's own (depth-first order).  The
forward pass computes the upper triangle (columns c >= i's first coordinate), the lower is its mirror.
Cost: O(n d) backward (d the depth) and O(n^2) forward.  A joint whose D_i is not positive (it moves no
mass or inertia) makes M singular: the kernel returns that body's index.  1-dof joints (nearly all) take
loops specialised with their 6-vectors in locals; the free joint the generic ones.

The algorithm is the core's (``core/minverse.cpp``); this module checks the arguments and calls it.
"""

import numpy as np

from . import _core, checks
from .parallel import run


def inverse_mass_matrix(model, q):
    """M(q)^-1, (nv, nv) or (B, nv, nv), computed directly in O(n^2) (not by inverting M; module docstring).

    Raises InputError naming the joint when M is singular (a joint that moves no mass or inertia)."""
    try:  # one state: one core call, which checks q (anything else takes the general path)
        Minv = _core.inverse_mass_matrix(model.core, q)
        if Minv is not None:
            return Minv
    except checks.NOT_A_MODEL:
        pass
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    out = run(_core.minverse_batch, model, Q, out=np.empty((Q.shape[0], model.nv, model.nv)),
              singular="inverse mass matrix")
    return out if batched else out[0]
