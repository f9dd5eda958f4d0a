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

The algorithm is the core's (``core/aba.cpp``); this module checks the arguments and calls it.
"""

from typing import NamedTuple

import numpy as np

from . import _core, checks
from ._numba import helper, inline_kernel, kernel
from .constrained_dynamics import constrained_forward_dynamics
from .data import Data, _data_at, _forward_body, _take
from .joints import _joint_motion
from .parallel import run
from .rnea import bias_forces, inverse_dynamics
from .spatial import (_add_inertia6_to_parent, _joint_gram, _spd_inverse, _store_inertia6, add, cross_force,
                      force_to_parent, inertia_times, load3, load33, motion_to_child)


def refuse_singular(model, q, what):
    """Raise :func:`~dynamics.checks.singular_joint_error` when the mass matrix is singular at q: the
    articulated-body pivot D = S^T I^A S of some joint is not positive definite.  The rule ``simulate`` applies to
    q0 and ``dynamics check`` to the neutral configuration, so both say the same."""
    zero = np.zeros((1, model.nv))
    run(_core.aba_batch, model, np.ascontiguousarray(q, dtype=float).reshape(1, model.nq), zero, zero, checks.external_forces(model, None, 1),
        np.zeros(3), False, out=np.empty((1, model.nv)), singular=what)


def forward_dynamics(model, q, v, tau, *, gravity=None, f_ext=None):
    """Joint accelerations a = M^-1 (tau - C v - g + J^T f_ext) by the ABA, O(n).

    Shapes as :func:`dynamics.inverse_dynamics` with tau in place of a.  Raises InputError naming the
    joint when the mass matrix is singular (a joint that moves no mass or inertia).

    On a constrained model (``model.constraints``: loops, a gripper's mimic couplings) the accelerations honour
    the constraints: the ``a`` of :func:`dynamics.constrained_forward_dynamics` without Baumgarte terms (use that
    function for the multipliers or stabilisation), with f_ext entering as its generalised force J^T f_ext.
    """
    if getattr(model, "constraints", None):
        return _constrained(model, q, v, tau, gravity, f_ext)
    if gravity is None and f_ext is None:  # one state: one core call, which checks q, v and tau itself
        try:
            qdd = _core.aba(model.core, q, v, tau)
            if qdd is not None:
                return qdd
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    checks.check_model(model)
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    out = run(_core.aba_batch, model, Q, V, T, F, g, bool(V.any()), out=np.empty((B, model.nv)),
              singular="forward dynamics")
    return out if batched else out[0]


def _constrained(model, q, v, tau, gravity, f_ext):
    """forward_dynamics on a constrained model.  f_ext's generalised force J^T f_ext is read off the RNEA:
    ID(q, v, 0) - ID(q, v, 0, f_ext) (the same gravity in both, so it cancels)."""
    if f_ext is not None:
        ext = bias_forces(model, q, v, gravity=gravity) - inverse_dynamics(model, q, v, np.zeros(model.nv),
                                                                          gravity=gravity, f_ext=f_ext)
        tau = np.asarray(tau, dtype=float)
        if tau.shape[-1:] == (model.nv,):  # (otherwise constrained_forward_dynamics names the bad shape)
            tau = tau + ext
    return constrained_forward_dynamics(model, q, v, tau, gravity=gravity)[0]


# -- numba kernels that the simulation still calls (until it moves to the core) --------------------------------

class Work(NamedTuple):
    """ABA's scratch for one state: the forward pass's :class:`~dynamics.data.Data`; articulated inertias IA
    (nb, 6, 6) and bias forces pA (nb, 6); U = IA S (nv, 6), D^-1 (nb, 6, 6) and u (nv,) per joint; the
    accelerations (nb, 6); and small temporaries Ia, D (6, 6), pa, t (6,)."""

    d: Data
    IA: object
    pA: object
    U: object
    Dinv: object
    u: object
    acc: object
    Ia: object
    D: object
    pa: object
    t: object


@inline_kernel
def _work_at(base, o, nb, nv):
    """A :class:`Work` carved from the buffer at ``base`` from offset o (at base 0: only its size), and the
    offset after it."""
    d, o = _data_at(base, o, nb)
    IA, o = _take(base, o, (nb, 6, 6))
    pA, o = _take(base, o, (nb, 6))
    U, o = _take(base, o, (nv, 6))
    Dinv, o = _take(base, o, (nb, 6, 6))
    u, o = _take(base, o, nv)
    acc, o = _take(base, o, (nb, 6))
    Ia, o = _take(base, o, (6, 6))
    D, o = _take(base, o, (6, 6))
    pa, o = _take(base, o, 6)
    t, o = _take(base, o, 6)
    return Work(d, IA, pA, U, Dinv, u, acc, Ia, D, pa, t), o


@helper
def _workspace(nb, nv):
    """A :class:`Work` of owned arrays, which the caller may keep (the simulation's problem holds one)."""
    d = Data(np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)),
             np.empty((nb, 3)))
    return Work(d, np.empty((nb, 6, 6)), np.empty((nb, 6)), np.empty((nv, 6)), np.empty((nb, 6, 6)), np.empty(nv),
                np.empty((nb, 6)), np.empty((6, 6)), np.empty((6, 6)), np.empty(6), np.empty(6))


@helper
def _get6(A, i):
    return (A[i, 0], A[i, 1], A[i, 2]), (A[i, 3], A[i, 4], A[i, 5])


@helper
def _set6(A, i, x, y):
    A[i, 0], A[i, 1], A[i, 2] = x
    A[i, 3], A[i, 4], A[i, 5] = y


@kernel
def _aba_into(tree, q, v, tau, gravity, f_ext, ws, qdd):
    """ABA for one state into ``qdd``, through the passes' own kernels (those the simulation's right-hand side
    links).  Returns -1, or the index of a body whose joint sees a singular articulated inertia (then qdd is
    not valid)."""
    _rigid_body_terms(tree, q, v, f_ext, ws, True)
    return _aba_rest(tree, tau, gravity, ws, qdd)


@inline_kernel
def _aba_rest(tree, tau, gravity, ws, qdd):
    """Passes 2 and 3, after pass 1 (:func:`_rigid_body_terms`) filled ``ws``.  A caller may add external body
    forces in between, as p^A_i -= f_i (the simulation's contact forces, found from pass 1's poses and
    velocities).  Returns -1, or the body whose joint is singular."""
    singular = _articulated_inertias(tree, tau, ws)
    if singular >= 0:
        return singular
    _accelerations(tree, gravity, ws, qdd)
    return -1


def _rigid_body_pass(tree, q, v, f_ext, ws, with_v):
    """Pass 1: the forward pass (X_i, v_i, c_i), and I^A_i = I_i, p^A_i = v_i x* I_i v_i - f_ext_i."""
    mass, hs, Ios, d = tree.mass, tree.h, tree.Io, ws.d
    zero = (0.0, 0.0, 0.0)
    for i in range(tree.parents.shape[0]):
        R, p, w, vl, cw, cv = _forward_body(tree, i, q, v, d, with_v)
        m, h, Io = mass[i], load3(hs, i), load33(Ios, i)
        if with_v:
            hn, hf = inertia_times(m, h, Io, w, vl)
            bn, bf = cross_force(w, vl, hn, hf)
        else:
            bn, bf = zero, zero
        _store_inertia6(ws.IA, i, m, h, Io)  # I^A = I_i
        if f_ext.shape[0] > 0:
            bn = (bn[0] - f_ext[i, 3], bn[1] - f_ext[i, 4], bn[2] - f_ext[i, 5])
            bf = (bf[0] - f_ext[i, 0], bf[1] - f_ext[i, 1], bf[2] - f_ext[i, 2])
        _set6(ws.pA, i, bn, bf)


def _articulated_pass(tree, tau, ws):
    """Pass 2, from the leaves in: U, D^-1, u per joint, and I^A_p += X^T I^a X, p^A_p += X^T p^a with
    I^a = I^A - U D^-1 U^T and p^a = p^A + I^a c + U D^-1 u.  Returns -1, or a body whose D is singular."""
    parents, S, v_idx, nv_j, d = tree.parents, tree.S, tree.v_idx, tree.nv_j, ws.d
    IA, pA, U, Dinv, u, Ia, pa, t = ws.IA, ws.pA, ws.U, ws.Dinv, ws.u, ws.Ia, ws.pa, ws.t
    for i in range(parents.shape[0] - 1, -1, -1):
        k0, nj = v_idx[i], nv_j[i]
        for k in range(k0, k0 + nj):  # U = I^A S,  u = tau - S^T p^A
            for r in range(6):
                x = 0.0
                for cc in range(6):
                    x += IA[i, r, cc] * S[k, cc]
                U[k, r] = x
            x = tau[k]
            for r in range(6):
                x -= S[k, r] * pA[i, r]
            u[k] = x
        _joint_gram(S, U, k0, nj, ws.D)  # D = S^T U
        if not _spd_inverse(ws.D, nj, Dinv, i, Ia):
            return i
        par = parents[i]
        if par < 0:
            continue
        for r in range(6):
            pa[r] = pA[i, r]
            for cc in range(6):
                Ia[r, cc] = IA[i, r, cc]
        for a_ in range(nj):  # one joint coordinate at a time
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
        cw, cv = load3(d.cw, i), load3(d.cv, i)
        for r in range(6):
            t[r] = (pa[r] + Ia[r, 0] * cw[0] + Ia[r, 1] * cw[1] + Ia[r, 2] * cw[2] + Ia[r, 3] * cv[0]
                    + Ia[r, 4] * cv[1] + Ia[r, 5] * cv[2])
        R, p = load33(d.R, i), load3(d.p, i)
        _add_inertia6_to_parent(R, p, Ia, IA, par)
        fn, ff = force_to_parent(R, p, (t[0], t[1], t[2]), (t[3], t[4], t[5]))
        pn, pf = _get6(pA, par)
        _set6(pA, par, add(pn, fn), add(pf, ff))
    return -1


def _acceleration_pass(tree, gravity, ws, qdd):
    """Pass 3, from the root out: a'_i = X_i a_p + c_i (a_0 = (0, -g)), qdd_i = D_i^-1 (u_i - U_i^T a'_i),
    a_i = a'_i + S_i qdd_i."""
    parents, v_idx, nv_j, d = tree.parents, tree.v_idx, tree.nv_j, ws.d
    U, Dinv, u, acc, t = ws.U, ws.Dinv, ws.u, ws.acc, ws.t
    zero = (0.0, 0.0, 0.0)
    a0 = (-gravity[0], -gravity[1], -gravity[2])
    for i in range(parents.shape[0]):
        par = parents[i]
        R, p = load33(d.R, i), load3(d.p, i)
        if par < 0:
            aw, al = motion_to_child(R, p, zero, a0)
        else:
            awp, alp = _get6(acc, par)
            aw, al = motion_to_child(R, p, awp, alp)
        aw, al = add(aw, load3(d.cw, i)), add(al, load3(d.cv, i))
        k0, nj = v_idx[i], nv_j[i]
        for a_ in range(nj):  # u - U^T a'
            k = k0 + a_
            t[a_] = (u[k] - U[k, 0] * aw[0] - U[k, 1] * aw[1] - U[k, 2] * aw[2]
                     - U[k, 3] * al[0] - U[k, 4] * al[1] - U[k, 5] * al[2])
        for a_ in range(nj):
            x = 0.0
            for b_ in range(nj):
                x += Dinv[i, a_, b_] * t[b_]
            qdd[k0 + a_] = x
        sw, sv = _joint_motion(tree, i, qdd)
        _set6(acc, i, add(aw, sw), add(al, sv))


#: each pass as a kernel of its own (the simulation's right-hand side and the energies link them)
_rigid_body_terms = kernel(_rigid_body_pass)
_articulated_inertias = kernel(_articulated_pass)
_accelerations = kernel(_acceleration_pass)


