"""Forward dynamics by the Articulated Body Algorithm, O(n) (Featherstone 2008, sec. 7.3, Table 7.1).

    a = M(q)^-1 (tau - C(q, v) v - g(q) + J^T f_ext)

Pass 1 (forward): v_i = X_i v_p + S_i qd_i,  c_i = v_i x (S_i qd_i),  I^A_i = I_i,
                  p^A_i = v_i x* I_i v_i - f_ext_i.
Pass 2 (reverse): U_i = I^A_i S_i,  D_i = S_i^T U_i,  u_i = tau_i - S_i^T p^A_i,
                  I^a = I^A_i - U_i D_i^-1 U_i^T,  p^a = p^A_i + I^a c_i + U_i D_i^-1 u_i,
                  I^A_p += X_i^T I^a X_i,  p^A_p += X_i^T p^a.
Pass 3 (forward): a'_i = X_i a_p + c_i (a_0 = (0, -g)),  qdd_i = D_i^-1 (u_i - U_i^T a'_i),
                  a_i = a'_i + S_i qdd_i.

6x6 inertias are in (angular, linear) order in each body's frame.  A joint whose D_i is not positive (it
carries no mass or inertia it could move) makes M singular: the kernel stops and returns that body's index.
"""

import numpy as np
from numba import njit

from .joints import add_joint_motion, joint_transform
from .spatial import (add_cross_force, add_cross_motion, add_force_to_parent, add_inertia6_to_parent,
                      inertia_times_motion, motion_to_child, spd_inverse)


@njit(cache=True, nogil=True)
def workspace(nb, nv):
    return (np.empty((nb, 3, 3)), np.empty((nb, 3)),  # R, p
            np.empty((nb, 6)), np.empty((nb, 6)),  # velocity (w, v), bias acceleration c
            np.empty((nb, 6, 6)), np.empty((nb, 6)),  # IA, pA
            np.empty((nv, 6)), np.empty((nb, 6, 6)), np.empty(nv),  # U, Dinv, u
            np.empty((nb, 6)), np.empty((6, 3, 3)), np.empty((6, 6)), np.empty(6), np.empty(6),
            np.empty((3, 3)))


@njit(cache=True, nogil=True)
def aba_into(tree, q, v, tau, gravity, f_ext, ws, qdd):
    """ABA for one state into ``qdd``.  Returns -1, or the index of a body whose joint sees a singular
    articulated inertia (then qdd is not valid)."""
    R, p, vel, c, IA, pA, U, Dinv, u, acc, tmp, Ia, pa, t6, Rj = ws
    nb = tree.parents.shape[0]
    S = tree.S
    zero = np.zeros(3)
    for i in range(nb):
        joint_transform(tree, i, q, Rj, R[i], p[i])
        par = tree.parents[i]
        w, vl = vel[i, 0:3], vel[i, 3:6]
        if par < 0:
            motion_to_child(R[i], p[i], zero, zero, w, vl)
        else:
            motion_to_child(R[i], p[i], vel[par, 0:3], vel[par, 3:6], w, vl)
        t6[:] = 0.0
        add_joint_motion(tree, i, v, t6[0:3], t6[3:6])  # v_J
        for r in range(6):
            vel[i, r] += t6[r]
        c[i] = 0.0
        add_cross_motion(w, vl, t6[0:3], t6[3:6], c[i, 0:3], c[i, 3:6])
        # I^A = I_i as a 6x6 matrix; p^A = v x* I v - f_ext
        m, h, Io = tree.mass[i], tree.h[i], tree.Io[i]
        IA[i] = 0.0
        for r in range(3):
            for k in range(3):
                IA[i, r, k] = Io[r, k]
            IA[i, 3 + r, 3 + r] = m
        IA[i, 0, 4], IA[i, 0, 5], IA[i, 1, 5] = -h[2], h[1], -h[0]
        IA[i, 1, 3], IA[i, 2, 3], IA[i, 2, 4] = h[2], -h[1], h[0]
        for r in range(3):
            for k in range(3):
                IA[i, 3 + k, r] = IA[i, r, 3 + k]
        inertia_times_motion(m, h, Io, w, vl, t6[0:3], t6[3:6])
        pA[i] = 0.0
        add_cross_force(w, vl, t6[0:3], t6[3:6], pA[i, 0:3], pA[i, 3:6])
        if f_ext.shape[0] > 0:
            for r in range(3):
                pA[i, r] -= f_ext[i, 3 + r]
                pA[i, 3 + r] -= f_ext[i, r]

    for i in range(nb - 1, -1, -1):
        k0 = tree.v_idx[i]
        nj = tree.nv_j[i]
        for k in range(k0, k0 + nj):
            for r in range(6):
                s = 0.0
                for cc in range(6):
                    s += IA[i, r, cc] * S[k, cc]
                U[k, r] = s
            s = tau[k]
            for r in range(6):
                s -= S[k, r] * pA[i, r]
            u[k] = s
        for a_ in range(nj):  # D = S^T U, inverted in place of Ia's first block
            for b_ in range(nj):
                s = 0.0
                for r in range(6):
                    s += S[k0 + a_, r] * U[k0 + b_, r]
                Ia[a_, b_] = s
        if not spd_inverse(Ia, nj, Dinv[i]):
            return i
        par = tree.parents[i]
        if par < 0:
            continue
        # I^a = I^A - U Dinv U^T and p^a = p^A + I^a c + U Dinv u, one joint coordinate at a time
        Ia[:, :] = IA[i]
        pa[:] = 0.0
        for a_ in range(nj):
            du = 0.0
            for b_ in range(nj):
                du += Dinv[i, a_, b_] * u[k0 + b_]
            for r in range(6):
                UD = 0.0  # (U Dinv)[r, a_]
                for b_ in range(nj):
                    UD += U[k0 + b_, r] * Dinv[i, b_, a_]
                for cc in range(6):
                    Ia[r, cc] -= UD * U[k0 + a_, cc]
                pa[r] += U[k0 + a_, r] * du
        for r in range(6):
            s = pA[i, r] + pa[r]
            for cc in range(6):
                s += Ia[r, cc] * c[i, cc]
            pa[r] = s
        add_inertia6_to_parent(R[i], p[i], Ia, IA[par], tmp)
        add_force_to_parent(R[i], p[i], pa[0:3], pa[3:6], pA[par, 0:3], pA[par, 3:6])

    minus_g = -gravity
    for i in range(nb):
        par = tree.parents[i]
        aw, al = acc[i, 0:3], acc[i, 3:6]
        if par < 0:
            motion_to_child(R[i], p[i], zero, minus_g, aw, al)
        else:
            motion_to_child(R[i], p[i], acc[par, 0:3], acc[par, 3:6], aw, al)
        for r in range(6):
            acc[i, r] += c[i, r]
        k0 = tree.v_idx[i]
        nj = tree.nv_j[i]
        for a_ in range(nj):
            s = u[k0 + a_]
            for r in range(6):
                s -= U[k0 + a_, r] * acc[i, r]
            t6[a_] = s
        for a_ in range(nj):
            s = 0.0
            for b_ in range(nj):
                s += Dinv[i, a_, b_] * t6[b_]
            qdd[k0 + a_] = s
        add_joint_motion(tree, i, qdd, aw, al)
    return -1


@njit(cache=True, nogil=True)
def aba(tree, q, v, tau, gravity, f_ext):
    """Joint accelerations for one state (allocates; callable from other kernels).  A singular joint gives
    NaN accelerations."""
    nb = tree.parents.shape[0]
    nv = tree.S.shape[0]
    qdd = np.empty(nv)
    if aba_into(tree, q, v, tau, gravity, f_ext, workspace(nb, nv), qdd) >= 0:
        qdd[:] = np.nan
    return qdd


@njit(cache=True, nogil=True)
def aba_batch(tree, Q, V, T, F, gravity, out, status):
    ws = workspace(tree.parents.shape[0], tree.S.shape[0])
    last = F.shape[0] - 1
    for b in range(Q.shape[0]):
        status[b] = aba_into(tree, Q[b], V[b], T[b], gravity, F[min(b, last)], ws, out[b])


# -- public entry point ----------------------------------------------------------------------------
from . import batch as _b  # noqa: E402


def _aba_chunk(tree, Q, V, T, F, gravity, out):
    status = np.empty(Q.shape[0], np.int64)
    aba_batch(tree, Q, V, T, F, gravity, out, status)
    bad = status[status >= 0]
    if bad.size:
        raise _SingularJoint(int(bad[0]))


class _SingularJoint(Exception):
    def __init__(self, body):
        self.body = body


def forward_dynamics(model, q, v, tau, *, gravity=None, f_ext=None):
    """Joint accelerations a = M^-1 (tau - C v - g + J^T f_ext) by the ABA, O(n).

    Shapes as :func:`dynamics.inverse_dynamics` with tau in place of a.  Raises InputError naming the
    joint when the mass matrix is singular (a joint that moves no mass or inertia).
    """
    _b.check_model(model)
    Q, bq = _b.configurations(model, q)
    V, bv = _b.states("v", v, model.nv)
    T, bt = _b.states("tau", tau, model.nv)
    Q, V, T = _b.broadcast((("q", Q), ("v", V), ("tau", T)))
    B = Q.shape[0]
    out = np.empty((B, model.nv))
    F = _b.external_forces(model, f_ext, B)
    g = _b.gravity_vector(model, gravity)
    try:
        _b.run_chunks(_aba_chunk, model.tree, (Q, V, T, F), (g,), out)
    except _SingularJoint as e:
        name = model.joint_names[e.body]
        raise _b.InputError(
            f"forward dynamics: the mass matrix is singular at joint {name!r}: it moves no mass or inertia "
            f"(add mass below it, lock it with dynamics.lock_joints, or remove it)") from None
    return out if (bq or bv or bt) else out[0]
