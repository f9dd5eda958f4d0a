"""Joint-space mass matrix by the Composite Rigid Body Algorithm (Featherstone 2008, sec. 6.2, Table 6.2).

    M(q) = sum_i J_i^T I_i J_i

Backward pass: the composite inertia of the subtree at i, I^c_i = I_i + sum_children X_c^T I^c_c X_c, kept as
(m, h, Io) in body i's frame.  For each velocity coordinate k of joint i, F = I^c_i S_k gives
M[k, dofs(i)] = S_i^T F, then F is carried to each ancestor j (F = X_j^T F) for M[k, dofs(j)] = S_j^T F.
Only the lower triangle is computed; the upper one is its mirror.
"""

import numpy as np
from numba import njit

from .joints import joint_transform
from .spatial import add_force_to_parent, inertia_times_motion, inertia_to_parent


@njit(cache=True, nogil=True)
def workspace(nb):
    """Scratch: poses (R, p), composite inertias (m, h, Io), a force (n, f) and a 3x3 temporary."""
    return (np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty(nb), np.empty((nb, 3)), np.empty((nb, 3, 3)),
            np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty((3, 3)))


@njit(cache=True, nogil=True)
def crba_into(tree, q, ws, M):
    R, p, mc, hc, Ioc, n, f, n2, f2, Rj = ws
    nb = tree.parents.shape[0]
    S = tree.S
    for i in range(nb):
        joint_transform(tree, i, q, Rj, R[i], p[i])
        mc[i] = tree.mass[i]
        hc[i] = tree.h[i]
        Ioc[i] = tree.Io[i]
    for i in range(nb - 1, -1, -1):
        par = tree.parents[i]
        if par >= 0:
            mc[par] += mc[i]
            inertia_to_parent(R[i], p[i], mc[i], hc[i], Ioc[i], hc[par], Ioc[par])
        for k in range(tree.v_idx[i], tree.v_idx[i] + tree.nv_j[i]):
            inertia_times_motion(mc[i], hc[i], Ioc[i], S[k, 0:3], S[k, 3:6], n, f)
            j = i
            while True:
                for c in range(tree.v_idx[j], tree.v_idx[j] + tree.nv_j[j]):
                    if c <= k:
                        x = (S[c, 0] * n[0] + S[c, 1] * n[1] + S[c, 2] * n[2]
                             + S[c, 3] * f[0] + S[c, 4] * f[1] + S[c, 5] * f[2])
                        M[k, c] = x
                        M[c, k] = x
                pj = tree.parents[j]
                if pj < 0:
                    break
                n2[:] = 0.0
                f2[:] = 0.0
                add_force_to_parent(R[j], p[j], n, f, n2, f2)
                n[:] = n2
                f[:] = f2
                j = pj


@njit(cache=True, nogil=True)
def crba(tree, q):
    """Mass matrix for one state (allocates; callable from other kernels).  Entries of unrelated
    branches are zero."""
    nv = tree.S.shape[0]
    M = np.zeros((nv, nv))
    crba_into(tree, q, workspace(tree.parents.shape[0]), M)
    return M


@njit(cache=True, nogil=True)
def crba_batch(tree, Q, out):
    ws = workspace(tree.parents.shape[0])
    out[:] = 0.0
    for b in range(Q.shape[0]):
        crba_into(tree, Q[b], ws, out[b])


# -- public entry point ----------------------------------------------------------------------------
from . import batch as _b  # noqa: E402


def mass_matrix(model, q):
    """The joint-space mass matrix M(q) (CRBA), symmetric positive definite: (nv, nv) or (B, nv, nv)."""
    _b.check_model(model)
    Q, batched = _b.configurations(model, q)
    out = np.empty((Q.shape[0], model.nv, model.nv))
    _b.run_chunks(crba_batch, model.tree, (Q,), (), out)
    return out if batched else out[0]
