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

from . import checks
from ._numba import (PACKED, VECTOR, Kernel, PythonFunction, borrowing_kernel, helper_kernel, inline_kernel,
                     keep_alive, kernel, py_array, py_status, scratch, view)
from .checks import DONE, GENERAL, config_ok, nonzero, py_packed, py_result, py_state, vector_ok
from .constrained import constrained_forward_dynamics
from .joints import joint_motion, joint_transform
from .model import unpack
from .parallel import run_chunks
from .rnea import bias_forces, inverse_dynamics
from .spatial import (add, add_inertia6_to_parent, cross_force, cross_motion, force_to_parent, inertia_times,
                      joint_gram, load3, load33, motion_to_child, spd_inverse, store3, store33, store_inertia6)


@kernel
def workspace(nb, nv):
    return (np.empty((nb, 3, 3)), np.empty((nb, 3)),  # R, p
            np.empty((nb, 6)), np.empty((nb, 6)),  # velocity (w, v), bias acceleration c
            np.empty((nb, 6, 6)), np.empty((nb, 6)),  # IA, pA
            np.empty((nv, 6)), np.empty((nb, 6, 6)), np.empty(nv),  # U, Dinv, u
            np.empty((nb, 6)), np.empty((6, 6)), np.empty((6, 6)), np.empty(6), np.empty(6))  # a, Ia, D, pa, t


@inline_kernel
def workspace_in(buf, nb, nv):
    """The same scratch as :func:`workspace`, borrowed from ``buf`` (108 nb + 7 nv + 84 floats, kept alive by
    the caller)."""
    return (view(buf, 0, (nb, 3, 3)), view(buf, 9 * nb, (nb, 3)),
            view(buf, 12 * nb, (nb, 6)), view(buf, 18 * nb, (nb, 6)),
            view(buf, 24 * nb, (nb, 6, 6)), view(buf, 60 * nb, (nb, 6)),
            view(buf, 66 * nb, (nv, 6)), view(buf, 66 * nb + 6 * nv, (nb, 6, 6)), view(buf, 102 * nb + 6 * nv, nv),
            view(buf, 102 * nb + 7 * nv, (nb, 6)), view(buf, 108 * nb + 7 * nv, (6, 6)),
            view(buf, 108 * nb + 7 * nv + 36, (6, 6)), view(buf, 108 * nb + 7 * nv + 72, 6),
            view(buf, 108 * nb + 7 * nv + 78, 6))


@helper_kernel
def _get6(A, i):
    return (A[i, 0], A[i, 1], A[i, 2]), (A[i, 3], A[i, 4], A[i, 5])


@helper_kernel
def _set6(A, i, x, y):
    A[i, 0], A[i, 1], A[i, 2] = x
    A[i, 3], A[i, 4], A[i, 5] = y


@borrowing_kernel
def aba_into(tree, q, v, tau, gravity, f_ext, ws, qdd):
    """ABA for one state into ``qdd``.  Returns -1, or the index of a body whose joint sees a singular
    articulated inertia (then qdd is not valid).  The simulation's (its problem calls it through an address):
    compiled without reference counting, since it allocates nothing and its callers hold every array (a fifth
    less to compile)."""
    return aba_terms(tree, q, v, tau, gravity, f_ext, ws, qdd, True)


@inline_kernel
def aba_terms(tree, q, v, tau, gravity, f_ext, ws, qdd, with_v):
    """ABA for one state; ``with_v=False`` (v is zero) skips the velocity products c_i and v x* I v.

    Longer than our ~80-line rule on purpose: it is Featherstone's three passes (RBDA Table 7.1) in one kernel,
    each pass a plain loop over the bodies with the 1-dof and free-joint cases written out, reading like the
    book from top to bottom; split into three functions, the passes would trade the same 14 workspace arrays
    and the reader would lose the one place where the recursion is whole."""
    parents, mass, hs, Ios, S, v_idx, nv_j = tree.parents, tree.mass, tree.h, tree.Io, tree.S, tree.v_idx, tree.nv_j
    Rs, ps, vel, c, IA, pA, U, Dinv, u, acc, Ia, D, pa, t = ws
    nb = parents.shape[0]
    zero = (0.0, 0.0, 0.0)
    # pass 1: velocities, bias accelerations, rigid-body inertias and bias forces
    for i in range(nb):
        R, p = joint_transform(tree, i, q)
        store33(Rs, i, R)
        store3(ps, i, p)
        par = parents[i]
        m, h, Io = mass[i], load3(hs, i), load33(Ios, i)
        if with_v:
            if par < 0:
                w, vl = motion_to_child(R, p, zero, zero)
            else:
                wp, vp = _get6(vel, par)
                w, vl = motion_to_child(R, p, wp, vp)
            wJ, vJ = joint_motion(tree, i, v)
            w, vl = add(w, wJ), add(vl, vJ)
            _set6(vel, i, w, vl)
            cw, cv = cross_motion(w, vl, wJ, vJ)
            _set6(c, i, cw, cv)
            hn, hf = inertia_times(m, h, Io, w, vl)
            bn, bf = cross_force(w, vl, hn, hf)
        else:
            _set6(c, i, zero, zero)
            bn, bf = zero, zero
        store_inertia6(IA, i, m, h, Io)  # I^A = I_i
        if f_ext.shape[0] > 0:
            bn = (bn[0] - f_ext[i, 3], bn[1] - f_ext[i, 4], bn[2] - f_ext[i, 5])
            bf = (bf[0] - f_ext[i, 0], bf[1] - f_ext[i, 1], bf[2] - f_ext[i, 2])
        _set6(pA, i, bn, bf)

    # pass 2: articulated inertias from the leaves in
    for i in range(nb - 1, -1, -1):
        k0 = v_idx[i]
        nj = nv_j[i]
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
        joint_gram(S, U, k0, nj, D)  # D = S^T U
        if not spd_inverse(D, nj, Dinv, i, Ia):
            return i
        par = parents[i]
        if par < 0:
            continue
        # I^a = I^A - U Dinv U^T and p^a = p^A + I^a c + U Dinv u, one joint coordinate at a time
        for r in range(6):
            pa[r] = pA[i, r]
            for cc in range(6):
                Ia[r, cc] = IA[i, r, cc]
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
            x = pa[r]
            for cc in range(6):
                x += Ia[r, cc] * c[i, cc]
            t[r] = x
        R, p = load33(Rs, i), load3(ps, i)
        add_inertia6_to_parent(R, p, Ia, IA, par)
        fn, ff = force_to_parent(R, p, (t[0], t[1], t[2]), (t[3], t[4], t[5]))
        pn, pf = _get6(pA, par)
        _set6(pA, par, add(pn, fn), add(pf, ff))

    # pass 3: accelerations from the root out
    a0 = (-gravity[0], -gravity[1], -gravity[2])
    for i in range(nb):
        par = parents[i]
        R, p = load33(Rs, i), load3(ps, i)
        if par < 0:
            aw, al = motion_to_child(R, p, zero, a0)
        else:
            awp, alp = _get6(acc, par)
            aw, al = motion_to_child(R, p, awp, alp)
        cw, cv = _get6(c, i)
        aw, al = add(aw, cw), add(al, cv)
        k0 = v_idx[i]
        nj = nv_j[i]
        for a_ in range(nj):  # u - U^T a'
            k = k0 + a_
            t[a_] = (u[k] - U[k, 0] * aw[0] - U[k, 1] * aw[1] - U[k, 2] * aw[2]
                     - U[k, 3] * al[0] - U[k, 4] * al[1] - U[k, 5] * al[2])
        for a_ in range(nj):
            x = 0.0
            for b_ in range(nj):
                x += Dinv[i, a_, b_] * t[b_]
            qdd[k0 + a_] = x
        sw, sv = joint_motion(tree, i, qdd)
        _set6(acc, i, add(aw, sw), add(al, sv))
    return -1


@kernel
def aba_batch(tree, Q, V, T, F, gravity, with_v, out, status):
    ws = workspace(tree.parents.shape[0], tree.S.shape[0])
    lf, lv, lt = F.shape[0] - 1, V.shape[0] - 1, T.shape[0] - 1
    for b in range(Q.shape[0]):
        status[b] = aba_terms(tree, Q[b], V[min(b, lv)], T[min(b, lt)], gravity, F[min(b, lf)], ws, out[b], with_v)


@kernel
def aba_single(packed, q, v, tau, qdd):
    """One state from Python, inputs checked in the call (status codes of :mod:`dynamics.checks`; a singular
    joint takes the general path, which names it)."""
    tree, gravity, nq = unpack(packed)
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    if not (config_ok(tree, nq, q) and vector_ok(v, nv) and vector_ok(tau, nv) and qdd.shape[0] == nv):
        return GENERAL
    buf = scratch(108 * nb + 7 * nv + 84)
    singular = aba_terms(tree, q, v, tau, gravity, view(buf, 0, (0, 6)), workspace_in(buf, nb, nv), qdd, nonzero(v))
    keep_alive(buf)
    return DONE if singular < 0 else GENERAL


def aba_entry(self, args, nargs):
    """forward_dynamics' one call from Python (dynamics._numba.PythonFunction): (packed, q, v, tau, qdd) -> status."""
    status = GENERAL
    if (nargs == 5 and py_packed(self, args[0]) and py_state(self, args[1]) and py_state(self, args[2])
            and py_state(self, args[3]) and py_result(self, args[4], 1)):
        status = aba_single(py_array(args[0], PACKED), py_array(args[1], VECTOR), py_array(args[2], VECTOR),
                            py_array(args[3], VECTOR), py_array(args[4], VECTOR))
    return py_status(self, status)


# -- public entry point ----------------------------------------------------------------------------
_aba_batch = Kernel(aba_batch)
_aba_single = PythonFunction(aba_entry, (DONE, GENERAL))


def _aba_chunk(tree, Q, V, T, F, gravity, with_v, out):
    status = np.empty(Q.shape[0], np.int64)
    _aba_batch(tree, Q, V, T, F, gravity, with_v, out, status)
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

    On a constrained model (``model.constraints``: loops, a gripper's mimic couplings) the accelerations honour
    the constraints: the ``a`` of :func:`dynamics.constrained_forward_dynamics` without Baumgarte terms (use that
    function for the multipliers or stabilisation), with f_ext entering as its generalised force J^T f_ext.
    """
    if getattr(model, "constraints", None):
        return _constrained(model, q, v, tau, gravity, f_ext)
    try:  # one state: one compiled call, which checks q, v and tau itself (anything else takes the general path)
        if gravity is None and f_ext is None:
            qdd = np.empty(model.nv)
            if _aba_single.call(model.packed, q, v, tau, qdd) == DONE:
                return qdd
    except AttributeError:  # not a model: the general path says so
        pass
    checks.check_model(model)
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    out = np.empty((B, model.nv))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    try:
        run_chunks(_aba_chunk, model.tree, (Q, V, T, F), (g, bool(V.any())), out)
    except _SingularJoint as e:
        raise checks.singular_joint_error(model, e.body, "forward dynamics") from None
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
