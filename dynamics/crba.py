"""Joint-space mass matrix by the Composite Rigid Body Algorithm (Featherstone 2008, sec. 6.2, Table 6.2).

    M(q) = sum_i J_i^T I_i J_i

Backward pass: the composite inertia of the subtree at i, I^c_i = I_i + sum_children X_c^T I^c_c X_c, kept as
(m, h, Io) in body i's frame.  For each velocity coordinate k of joint i, F = I^c_i S_k gives
M[k, dofs(i)] = S_i^T F, then F is carried to each ancestor j (F = X_j^T F) for M[k, dofs(j)] = S_j^T F.
Only the lower triangle is computed; the upper one is its mirror.

The algorithm is the core's (``core/crba.cpp``); this module checks the arguments and calls it.
"""

import numpy as np

from . import _core, checks
from .parallel import run


def mass_matrix(model, q):
    """The joint-space mass matrix M(q) (CRBA), symmetric positive definite: (nv, nv) or (B, nv, nv)."""
    try:  # one state: one core call, which checks q itself (anything else takes the general path)
        M = _core.crba(model.core, q)
        if M is not None:
            return M
    except checks.NOT_A_MODEL:  # the general path says what is wrong
        pass
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    # numpy's zeros: fresh pages, zeroed by the kernel where the threads first write them; the CRBA leaves the
    # entries between branches alone, so nothing fills the output a second time
    out = run(_zeroed_crba_batch, model, Q, out=np.zeros((Q.shape[0], model.nv, model.nv)))
    return out if batched else out[0]


def _zeroed_crba_batch(core, Q, out, threads, seconds):
    return _core.crba_batch(core, Q, out, threads, seconds, True)

