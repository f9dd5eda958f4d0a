"""A Coriolis matrix C(q, v) with C v = bias_forces - g(q) and dM/dt - 2C skew-symmetric.

C is not unique; this is the factorisation of Echeandia & Wensing (2021, "A numerical method for computing
the Coriolis matrix", eq. 28), written in body coordinates:

    C = sum_i J_i^T [ I_i dJ_i + 1/2 ( v_i x* I_i + I_i v_i x + (I_i v_i) xbar ) J_i ]

where J_i is body i's Jacobian in its own frame, dJ_i its time derivative and (f xbar) v = v x* f.  Its
skew-symmetry follows from dM/dt = sum (dJ^T I J + J^T I dJ) because v x* I + I v x and (I v) xbar are both
skew.  Recursion for the Jacobian columns of the ancestors of i (parent p, joint velocity v_J = S_i qd_i):

    J_i = X_i J_p (+ S_i on i's own columns),   dJ_i = X_i dJ_p - v_J x (X_i J_p)   (own columns: 0).

Cost is O(n d^2) for depth d: it is meant for analysis and control design, not for inner loops.
"""

import numpy as np
from numba import njit

from .joints import add_joint_motion, joint_transform
from .spatial import add_cross_motion, motion_to_child


@njit(cache=True, nogil=True)
def _cross_matrices(I, w, vl, B):
    """B = 1/2 (v x* I + I v x + (I v) xbar) for the 6x6 inertia I and motion (w, vl)."""
    crm = np.zeros((6, 6))  # v x
    for (r, c, s) in ((0, 1, -w[2]), (0, 2, w[1]), (1, 0, w[2]), (1, 2, -w[0]), (2, 0, -w[1]), (2, 1, w[0])):
        crm[r, c] = s
        crm[3 + r, 3 + c] = s
    for (r, c, s) in ((0, 1, -vl[2]), (0, 2, vl[1]), (1, 0, vl[2]), (1, 2, -vl[0]), (2, 0, -vl[1]), (2, 1, vl[0])):
        crm[3 + r, c] = s
    h = np.zeros(6)  # I v = (n, f)
    for r in range(6):
        for c in range(3):
            h[r] += I[r, c] * w[c] + I[r, 3 + c] * vl[c]
    xbar = np.zeros((6, 6))  # (n, f) xbar = [[-[n]x, -[f]x], [-[f]x, 0]]
    for (r, c, k, s) in ((0, 1, 2, 1.0), (0, 2, 1, -1.0), (1, 0, 2, -1.0), (1, 2, 0, 1.0), (2, 0, 1, 1.0),
                         (2, 1, 0, -1.0)):
        xbar[r, c] = s * h[k]
        xbar[r, 3 + c] = s * h[3 + k]
        xbar[3 + r, c] = s * h[3 + k]
    for r in range(6):
        for c in range(6):
            s = xbar[r, c]
            for k in range(6):
                s += -crm[k, r] * I[k, c] + I[r, k] * crm[k, c]  # v x* = -(v x)^T
            B[r, c] = 0.5 * s


@njit(cache=True, nogil=True)
def coriolis_kernel(tree, q, v, C):
    nb = tree.parents.shape[0]
    nv = tree.S.shape[0]
    R = np.empty((3, 3))
    Rj = np.empty((3, 3))
    p = np.empty(3)
    vel = np.zeros((nb, 6))
    J = np.zeros((nb, 6, nv))
    dJ = np.zeros((nb, 6, nv))
    cols = np.zeros((nb, nv), dtype=np.bool_)  # columns of J_i that can be non-zero (ancestors' dofs)
    vJ = np.empty(6)
    I6 = np.zeros((6, 6))
    Bm = np.empty((6, 6))
    Y = np.empty((6, nv))
    zero = np.zeros(3)
    C[:, :] = 0.0
    S = tree.S
    for i in range(nb):
        joint_transform(tree, i, q, Rj, R, p)
        par = tree.parents[i]
        vJ[:] = 0.0
        add_joint_motion(tree, i, v, vJ[0:3], vJ[3:6])
        if par < 0:
            motion_to_child(R, p, zero, zero, vel[i, 0:3], vel[i, 3:6])
        else:
            motion_to_child(R, p, vel[par, 0:3], vel[par, 3:6], vel[i, 0:3], vel[i, 3:6])
            for k in range(nv):
                if cols[par, k]:
                    cols[i, k] = True
                    motion_to_child(R, p, J[par, 0:3, k], J[par, 3:6, k], J[i, 0:3, k], J[i, 3:6, k])
                    motion_to_child(R, p, dJ[par, 0:3, k], dJ[par, 3:6, k], dJ[i, 0:3, k], dJ[i, 3:6, k])
                    # dJ -= v_J x J  (as += J x v_J)
                    add_cross_motion(J[i, 0:3, k], J[i, 3:6, k], vJ[0:3], vJ[3:6], dJ[i, 0:3, k], dJ[i, 3:6, k])
        for r in range(6):
            vel[i, r] += vJ[r]
        for k in range(tree.v_idx[i], tree.v_idx[i] + tree.nv_j[i]):
            cols[i, k] = True
            for r in range(6):
                J[i, r, k] = S[k, r]
        m, h, Io = tree.mass[i], tree.h[i], tree.Io[i]
        I6[:, :] = 0.0
        I6[0:3, 0:3] = Io
        for r in range(3):
            I6[3 + r, 3 + r] = m
        for (r, c, s) in ((0, 1, -h[2]), (0, 2, h[1]), (1, 0, h[2]), (1, 2, -h[0]), (2, 0, -h[1]), (2, 1, h[0])):
            I6[r, 3 + c] = s  # [h]x
            I6[3 + c, r] = s  # [h]x^T
        _cross_matrices(I6, vel[i, 0:3], vel[i, 3:6], Bm)
        for c in range(nv):
            if cols[i, c]:
                for r in range(6):
                    s = 0.0
                    for k in range(6):
                        s += I6[r, k] * dJ[i, k, c] + Bm[r, k] * J[i, k, c]
                    Y[r, c] = s
        for a_ in range(nv):
            if cols[i, a_]:
                for c in range(nv):
                    if cols[i, c]:
                        s = 0.0
                        for r in range(6):
                            s += J[i, r, a_] * Y[r, c]
                        C[a_, c] += s


@njit(cache=True, nogil=True)
def coriolis_batch(tree, Q, V, out):
    for b in range(Q.shape[0]):
        coriolis_kernel(tree, Q[b], V[b], out[b])


# -- public entry point ----------------------------------------------------------------------------
from . import batch as _b  # noqa: E402


def coriolis_matrix(model, q, v):
    """C(q, v), (nv, nv) or (B, nv, nv): C v + g(q) = bias_forces(q, v), dM/dt - 2C skew-symmetric."""
    _b.check_model(model)
    Q, bq = _b.configurations(model, q)
    V, bv = _b.states("v", v, model.nv)
    Q, V = _b.broadcast((("q", Q), ("v", V)))
    out = np.empty((Q.shape[0], model.nv, model.nv))
    _b.run_chunks(coriolis_batch, model.tree, (Q, V), (), out)
    return out if (bq or bv) else out[0]
