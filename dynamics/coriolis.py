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
from . import checks
from ._numba import borrow, address, keep_alive, kernel
from .parallel import run_chunks

from .data import _data_at, _forward_pass
from .joints import _joint_motion
from .spatial import add, cross_motion, load3, load33, motion_to_child


@kernel
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


@kernel
def _coriolis_kernel(tree, q, v, C):
    nb = tree.parents.shape[0]
    nv = tree.S.shape[0]
    buf = np.empty(_data_at(0, 0, nb)[1])
    d = _data_at(address(buf), 0, nb)[0]
    _forward_pass(tree, q, v, d, True)  # X_i, v_i
    J = np.zeros((nb, 6, nv))
    dJ = np.zeros((nb, 6, nv))
    cols = np.zeros((nb, nv), dtype=np.bool_)  # columns of J_i that can be non-zero (ancestors' dofs)
    I6 = np.zeros((6, 6))
    Bm = np.empty((6, 6))
    Y = np.empty((6, nv))
    C[:, :] = 0.0
    S = tree.S
    for i in range(nb):
        R, p = load33(d.R, i), load3(d.p, i)
        par = tree.parents[i]
        wJ, vJ = _joint_motion(tree, i, v)
        if par >= 0:  # J_i = X_i J_p (+ S_i),  dJ_i = X_i dJ_p + J_i x v_J (Featherstone 2008, sec. 7.2)
            for k in range(nv):
                if cols[par, k]:
                    cols[i, k] = True
                    jw, jv = motion_to_child(R, p, (J[par, 0, k], J[par, 1, k], J[par, 2, k]),
                                             (J[par, 3, k], J[par, 4, k], J[par, 5, k]))
                    dw, dv = motion_to_child(R, p, (dJ[par, 0, k], dJ[par, 1, k], dJ[par, 2, k]),
                                             (dJ[par, 3, k], dJ[par, 4, k], dJ[par, 5, k]))
                    xw, xv = cross_motion(jw, jv, wJ, vJ)  # dJ -= v_J x J, i.e. += J x v_J
                    dw, dv = add(dw, xw), add(dv, xv)
                    for r in range(3):
                        J[i, r, k], J[i, 3 + r, k] = jw[r], jv[r]
                        dJ[i, r, k], dJ[i, 3 + r, k] = dw[r], dv[r]
        w, vl = load3(d.w, i), load3(d.vl, i)
        for k in range(tree.v_idx[i], tree.v_idx[i] + tree.nv_j[i]):
            cols[i, k] = True
            for r in range(6):
                J[i, r, k] = S[k, r]
        m = tree.mass[i]
        h = (tree.h[i, 0], tree.h[i, 1], tree.h[i, 2])
        I6[:, :] = 0.0
        for r in range(3):
            for c in range(3):
                I6[r, c] = tree.Io[i, r, c]
            I6[3 + r, 3 + r] = m
        for (r, c, s) in ((0, 1, -h[2]), (0, 2, h[1]), (1, 0, h[2]), (1, 2, -h[0]), (2, 0, -h[1]), (2, 1, h[0])):
            I6[r, 3 + c] = s  # [h]x
            I6[3 + c, r] = s  # [h]x^T
        _cross_matrices(I6, w, vl, Bm)
        for c in range(nv):
            if cols[i, c]:
                for r in range(6):
                    x = 0.0
                    for k in range(6):
                        x += I6[r, k] * dJ[i, k, c] + Bm[r, k] * J[i, k, c]
                    Y[r, c] = x
        for a_ in range(nv):
            if cols[i, a_]:
                for c in range(nv):
                    if cols[i, c]:
                        x = 0.0
                        for r in range(6):
                            x += J[i, r, a_] * Y[r, c]
                        C[a_, c] += x
    keep_alive(buf)


@kernel
def _coriolis_batch(tree, Q, V, out):
    # the arguments as views with no owner: no reference counts in the loops (dynamics._numba.borrow)
    tree, Q, V = borrow(tree), borrow(Q), borrow(V)
    out = borrow(out)
    for b in range(Q.shape[0]):
        _coriolis_kernel(tree, Q[b], V[b], out[b])


# -- public entry point ----------------------------------------------------------------------------
_coriolis_batch = _coriolis_batch


def coriolis_matrix(model, q, v):
    """C(q, v), (nv, nv) or (B, nv, nv): C v + g(q) = bias_forces(q, v), dM/dt - 2C skew-symmetric."""
    checks.check_model(model)
    Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = np.empty((B, model.nv, model.nv))
    run_chunks(_coriolis_batch, model.tree, (Q, V), (), out)
    return out if batched else out[0]
