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
from ._numba import helper, inline_kernel, kernel
from .data import _take
from .joints import _joint_transform
from .parallel import run
from .spatial import add, force_to_parent, inertia_times, inertia_to_parent, load3, load33, store3, store33


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
    out = run(_core.crba_batch, model, Q, out=np.empty((Q.shape[0], model.nv, model.nv)))
    return out if batched else out[0]


# -- numba kernels that the constrained dynamics still calls (until it moves to the core) ------------------------

@helper
def _workspace(nb):
    """Scratch: poses (R, p) and composite inertias (m, h, Io)."""
    return np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty(nb), np.empty((nb, 3)), np.empty((nb, 3, 3))


@inline_kernel
def _work_at(base, o, nb):
    """The same scratch carved from the buffer at ``base`` from offset o, and the offset after it."""
    R, o = _take(base, o, (nb, 3, 3))
    p, o = _take(base, o, (nb, 3))
    m, o = _take(base, o, nb)
    h, o = _take(base, o, (nb, 3))
    Io, o = _take(base, o, (nb, 3, 3))
    return (R, p, m, h, Io), o


def _crba_into(tree, q, ws, M):
    """M (nv, nv) at q into M, whose entries between coordinates on different branches are not written (the
    caller zeroes M)."""
    parents, mass, hs, Ios, S, v_idx, nv_j = tree.parents, tree.mass, tree.h, tree.Io, tree.S, tree.v_idx, tree.nv_j
    Rs, ps, mc, hc, Ioc = ws
    nb = parents.shape[0]
    for i in range(nb):
        R, p = _joint_transform(tree, i, q)
        store33(Rs, i, R)
        store3(ps, i, p)
        mc[i] = mass[i]
        store3(hc, i, load3(hs, i))
        store33(Ioc, i, load33(Ios, i))
    for i in range(nb - 1, -1, -1):
        m, h, Io = mc[i], load3(hc, i), load33(Ioc, i)
        par = parents[i]
        if par >= 0:  # I^c_parent += X^T I^c_i X
            hP, IoP = inertia_to_parent(load33(Rs, i), load3(ps, i), m, h, Io)
            mc[par] += m
            store3(hc, par, add(load3(hc, par), hP))
            store33(Ioc, par, _add9(load33(Ioc, par), IoP))
        for k in range(v_idx[i], v_idx[i] + nv_j[i]):
            n, f = inertia_times(m, h, Io, (S[k, 0], S[k, 1], S[k, 2]), (S[k, 3], S[k, 4], S[k, 5]))  # F = I^c S_k
            j = i
            while True:  # M[k, dofs(j)] = S_j^T F for j = i and its ancestors
                for c in range(v_idx[j], v_idx[j] + nv_j[j]):
                    if c <= k:
                        x = (S[c, 0] * n[0] + S[c, 1] * n[1] + S[c, 2] * n[2]
                             + S[c, 3] * f[0] + S[c, 4] * f[1] + S[c, 5] * f[2])
                        M[k, c] = x
                        M[c, k] = x
                pj = parents[j]
                if pj < 0:
                    break
                n, f = force_to_parent(load33(Rs, j), load3(ps, j), n, f)
                j = pj


_crba_into = kernel(_crba_into)


@helper
def _add9(A, B):
    return (A[0] + B[0], A[1] + B[1], A[2] + B[2], A[3] + B[3], A[4] + B[4], A[5] + B[5], A[6] + B[6],
            A[7] + B[7], A[8] + B[8])


