"""Analytical derivatives of inverse dynamics (Carpentier and Mansard, "Analytical derivatives of rigid body
dynamics algorithms", RSS 2018; Pinocchio's ``computeRNEADerivatives``).

    tau = RNEA(q, v, a) = M(q) a + C(q, v) v + g(q) - sum_i J_i^T f_ext_i
    dtau/dq (in the tangent space), dtau/dv, dtau/da = M

Everything is expressed in the world frame (motions and forces at the world origin), so that moving a joint
moves its whole subtree rigidly.  A q derivative is taken along q (+) dq with dq in the joint's own frame
(the local tangent, as :func:`dynamics.integrate` and Pinocchio): the column of a joint's coordinate k is the
world motion J_k = oX_i S_k of its axis.

Forward pass (root out; p the parent of body i, ov_0 = 0, oa_0 = (0, -g)):

    J_k    = oX_i S_k                          (world axes of joint i)
    ov_i   = ov_p + J_i qd_i,     oa_i = oa_p + J_i qdd_i + ov_i x (J_i qd_i)
    dV_k   = ov_p x J_k           the world velocity change of the subtree along a q_k move, rigid part taken out
    dAq_k  = oa_p x J_k + ov_p x dV_k,      dAv_k = ov_i x J_k + dV_k
    f_i    = I_i oa_i + ov_i x* I_i ov_i - oX_i^-T f_ext_i          (I_i the body inertia in the world frame)
    dY_i   = ov_i x* I_i - I_i ov_i x + (h_i x*-matrix) = [[B_i, 0], [-2 [hf_i], 0]]
             with h_i = (hn_i, hf_i) = I_i ov_i and B_i = [w] Io - Io [w] - [vl][h] - [h][vl] - [hn]

Backward pass (leaves in), with composites Y_i = sum of I over the subtree of i, dY_i likewise, F_i = sum of f:

    tau_k = J_k^T F_i
    Fa_k = Y_i J_k,   Fv_k = dY_i J_k + Y_i dAv_k,   Fq_k = dY_i dV_k + Y_i dAq_k
    rows r of i or of an ancestor, columns k of i:  M[r, k] = J_r^T Fa_k,  dtau_r/dv_k = J_r^T Fv_k,
        dtau_r/dq_k = J_r^T Fq_k, where for r above i Fq_k also carries J_k x* F_i (the rigid motion of the
        subtree's forces; at r in i it cancels with the motion of J_r itself)
    rows k of i, columns c of a strict ancestor:  dtau_k/dv_c = (Y_i J_k)^T dAv_c + (dY_i^T J_k)^T J_c,
        dtau_k/dq_c = (Y_i J_k)^T dAq_c + (dY_i^T J_k)^T dV_c

Cost: O(n d) for n coordinates at tree depth d (the ancestor walk), as Pinocchio.

The public function is the core's (``core/rnea_derivatives.cpp``); this module checks the arguments and calls it.
The numba kernels below stay for the compiled callers that link them (the constrained dynamics' derivatives,
the torque sources', the kinematics derivatives) until those move to the core.
"""

from typing import NamedTuple

import numpy as np

from . import _core, checks
from ._numba import address, helper, inline_kernel, keep_alive, kernel
from .data import _take
from .joints import _joint_transform
from .parallel import run
from .spatial import (add, cross, cross_force, cross_motion, dot, dot6, force_to_parent, get6, inertia_times,
                      inertia_to_parent, load3, load33, matmul, motion_to_parent, rot, rotT, scale, set6, store3,
                      store33)


class Work(NamedTuple):
    """The derivatives' scratch for one state.  Per body (nb): world pose oR (3, 3), op (3); world velocity ov
    and acceleration oa (6, gravity included); composite inertia mass, h (3), Io (3, 3) about the world origin;
    dY's blocks B (3, 3) and hf (3); composite force F (6).  Per coordinate (nv, 6): J, dV, dAq, dAv, Fa, Fv,
    Fq (module docstring), and lv (nv, 3) the angular half of dY^T J; tau (nv,)."""

    oR: object
    op: object
    ov: object
    oa: object
    mass: object
    h: object
    Io: object
    B: object
    hf: object
    F: object
    J: object
    dV: object
    dAq: object
    dAv: object
    Fa: object
    Fv: object
    Fq: object
    lv: object
    tau: object


@inline_kernel
def _work_at(base, o, nb, nv):
    """A :class:`Work` carved from the buffer at ``base`` from offset o (at base 0: only its size), and the
    offset after it."""
    oR, o = _take(base, o, (nb, 3, 3))
    op, o = _take(base, o, (nb, 3))
    ov, o = _take(base, o, (nb, 6))
    oa, o = _take(base, o, (nb, 6))
    mass, o = _take(base, o, nb)
    h, o = _take(base, o, (nb, 3))
    Io, o = _take(base, o, (nb, 3, 3))
    B, o = _take(base, o, (nb, 3, 3))
    hf, o = _take(base, o, (nb, 3))
    F, o = _take(base, o, (nb, 6))
    J, o = _take(base, o, (nv, 6))
    dV, o = _take(base, o, (nv, 6))
    dAq, o = _take(base, o, (nv, 6))
    dAv, o = _take(base, o, (nv, 6))
    Fa, o = _take(base, o, (nv, 6))
    Fv, o = _take(base, o, (nv, 6))
    Fq, o = _take(base, o, (nv, 6))
    lv, o = _take(base, o, (nv, 3))
    tau, o = _take(base, o, nv)
    return Work(oR, op, ov, oa, mass, h, Io, B, hf, F, J, dV, dAq, dAv, Fa, Fv, Fq, lv, tau), o


@inline_kernel
def _derivatives_workspace(nb, nv):
    """A :class:`Work` for nb bodies and nv coordinates over one owned buffer; returns (buffer, work): keep the
    buffer alive as long as the work is used.  Compiled code only, inlined (a kernel of its own compiled a Python
    wrapper boxing the whole work)."""
    buf = np.empty(_work_at(0, 0, nb, nv)[1])
    return buf, _work_at(address(buf), 0, nb, nv)[0]


@helper
def _set_item(A, i, x):
    """A[i] = x.  Workspace items are set through a helper (as store3 does), never by a bare item assignment in
    an inlined kernel: next to a borrowed tree numba dropped such an assignment to a carved view as dead."""
    A[i] = x


@helper
def add33(A, B):
    return (A[0] + B[0], A[1] + B[1], A[2] + B[2], A[3] + B[3], A[4] + B[4], A[5] + B[5], A[6] + B[6], A[7] + B[7],
            A[8] + B[8])


@inline_kernel
def _velocity_variation(m, h, Io, w, vl):
    """The blocks (B, hf) of dY = ov x* I - I ov x + (I ov) x*-matrix = [[B, 0], [-2 [hf], 0]] (module
    docstring), for the inertia (m, h, Io) and the motion (w, vl), all in one frame."""
    hn, hf = inertia_times(m, h, Io, w, vl)
    W = (0.0, -w[2], w[1], w[2], 0.0, -w[0], -w[1], w[0], 0.0)
    WI, IW = matmul(W, Io), matmul(Io, W)
    s = 2.0 * dot(vl, h)  # [vl][h] + [h][vl] = h vl^T + vl h^T - 2 (vl . h) 1
    B = (WI[0] - IW[0] - 2.0 * h[0] * vl[0] + s, WI[1] - IW[1] - h[0] * vl[1] - vl[0] * h[1] + hn[2],
         WI[2] - IW[2] - h[0] * vl[2] - vl[0] * h[2] - hn[1], WI[3] - IW[3] - h[1] * vl[0] - vl[1] * h[0] - hn[2],
         WI[4] - IW[4] - 2.0 * h[1] * vl[1] + s, WI[5] - IW[5] - h[1] * vl[2] - vl[1] * h[2] + hn[0],
         WI[6] - IW[6] - h[2] * vl[0] - vl[2] * h[0] + hn[1], WI[7] - IW[7] - h[2] * vl[1] - vl[2] * h[1] - hn[0],
         WI[8] - IW[8] - 2.0 * h[2] * vl[2] + s)
    return B, hf


@inline_kernel
def _forward_step(tree, i, q, v, a, gravity, f_ext, ws):
    """Body i's step of the forward pass (its parent's is done): world pose, J, ov, oa, dV, dAq, dAv, the
    world inertia, dY and the body's force f_i."""
    cw, cv = _velocity_step(tree, i, q, v, f_ext, ws)
    _acceleration_step(tree, i, a, gravity, ws, cw, cv)


@inline_kernel
def _velocity_step(tree, i, q, v, f_ext, ws):
    """The part of body i's forward step that does not depend on the acceleration: world pose, J, ov, dV, dAv,
    the world inertia, dY, and F_i = ov_i x* I_i ov_i - f_ext_i (the ABA's bias force).  Returns
    ov_i x (J_i qd_i), the velocity product of oa_i (:func:`_acceleration_step`)."""
    R, p = _joint_transform(tree, i, q)
    par, S, k0, nj = tree.parents[i], tree.S, tree.v_idx[i], tree.nv_j[i]
    zero = (0.0, 0.0, 0.0)
    if par < 0:
        oR, op, vpw, vpv = R, p, zero, zero
    else:
        Rp = load33(ws.oR, par)
        oR, op = matmul(Rp, R), add(rot(Rp, p), load3(ws.op, par))
        vpw, vpv = get6(ws.ov, par)
    store33(ws.oR, i, oR)
    store3(ws.op, i, op)
    vjw, vjv = zero, zero
    for k in range(k0, k0 + nj):  # J_k = oX_i S_k;  J_i qd_i
        Jw, Jv = motion_to_parent(oR, op, (S[k, 0], S[k, 1], S[k, 2]), (S[k, 3], S[k, 4], S[k, 5]))
        set6(ws.J, k, Jw, Jv)
        vjw, vjv = add(vjw, scale(v[k], Jw)), add(vjv, scale(v[k], Jv))
    w, vl = add(vpw, vjw), add(vpv, vjv)
    set6(ws.ov, i, w, vl)
    for k in range(k0, k0 + nj):
        Jw, Jv = get6(ws.J, k)
        dJw, dJv = cross_motion(w, vl, Jw, Jv)
        dVw, dVv = cross_motion(vpw, vpv, Jw, Jv)
        set6(ws.dV, k, dVw, dVv)
        set6(ws.dAv, k, add(dJw, dVw), add(dJv, dVv))
    m = tree.mass[i]
    h, Io = inertia_to_parent(oR, op, m, load3(tree.h, i), load33(tree.Io, i))
    hn, hf = inertia_times(m, h, Io, w, vl)
    fn, ff = cross_force(w, vl, hn, hf)
    if f_ext.shape[0] > 0:  # f_ext_i in the body frame, [force, torque]
        en, ef = force_to_parent(oR, op, (f_ext[i, 3], f_ext[i, 4], f_ext[i, 5]),
                                 (f_ext[i, 0], f_ext[i, 1], f_ext[i, 2]))
        fn, ff = (fn[0] - en[0], fn[1] - en[1], fn[2] - en[2]), (ff[0] - ef[0], ff[1] - ef[1], ff[2] - ef[2])
    set6(ws.F, i, fn, ff)
    B, hf = _velocity_variation(m, h, Io, w, vl)
    _set_item(ws.mass, i, m)
    store3(ws.h, i, h)
    store33(ws.Io, i, Io)
    store33(ws.B, i, B)
    store3(ws.hf, i, hf)
    return cross_motion(w, vl, vjw, vjv)


@inline_kernel
def _acceleration_step(tree, i, a, gravity, ws, cw, cv):
    """The rest of body i's forward step, once its velocity step and its parent's steps are done and a is known
    at its joint: oa_i = oa_p + J_i qdd_i + (cw, cv), dAq and F_i += I_i oa_i."""
    par, k0, nj = tree.parents[i], tree.v_idx[i], tree.nv_j[i]
    zero = (0.0, 0.0, 0.0)
    if par < 0:
        vpw, vpv, apw, apv = zero, zero, zero, (-gravity[0], -gravity[1], -gravity[2])
    else:
        (vpw, vpv), (apw, apv) = get6(ws.ov, par), get6(ws.oa, par)
    ajw, ajv = zero, zero
    for k in range(k0, k0 + nj):
        Jw, Jv = get6(ws.J, k)
        ajw, ajv = add(ajw, scale(a[k], Jw)), add(ajv, scale(a[k], Jv))
        dVw, dVv = get6(ws.dV, k)
        qw, qv = cross_motion(apw, apv, Jw, Jv)
        xw, xv = cross_motion(vpw, vpv, dVw, dVv)
        set6(ws.dAq, k, add(qw, xw), add(qv, xv))
    aw, al = add(add(apw, ajw), cw), add(add(apv, ajv), cv)
    set6(ws.oa, i, aw, al)
    m, h, Io = ws.mass[i], load3(ws.h, i), load33(ws.Io, i)
    fn, ff = inertia_times(m, h, Io, aw, al)
    bn, bf = get6(ws.F, i)
    set6(ws.F, i, add(fn, bn), add(ff, bf))


@inline_kernel
def _dY_times(B, hf, w):
    """dY (w, .) = (B w, -2 hf x w): dY's right column is zero, so only the angular half of the motion acts."""
    c = cross(hf, w)
    return rot(B, w), (-2.0 * c[0], -2.0 * c[1], -2.0 * c[2])


@inline_kernel
def _backward_step(tree, i, ws, tau, dq, dv, M):
    """Body i's step of the backward pass (its subtree's composites are complete): the rows and columns of its
    coordinates against its own and its ancestors' (module docstring), then its composites into its parent."""
    k0, nj, J, Fa, Fv, Fq, lv = tree.v_idx[i], tree.nv_j[i], ws.J, ws.Fa, ws.Fv, ws.Fq, ws.lv
    m, h, Io, B, hf = ws.mass[i], load3(ws.h, i), load33(ws.Io, i), load33(ws.B, i), load3(ws.hf, i)
    fn, ff = get6(ws.F, i)
    for k in range(k0, k0 + nj):
        Jw, Jv = get6(J, k)
        set6(Fa, k, *inertia_times(m, h, Io, Jw, Jv))
        xw, xv = get6(ws.dAv, k)
        yn, yf = inertia_times(m, h, Io, xw, xv)
        zn, zf = _dY_times(B, hf, Jw)
        set6(Fv, k, add(yn, zn), add(yf, zf))
        xw, xv = get6(ws.dAq, k)
        yn, yf = inertia_times(m, h, Io, xw, xv)
        zn, zf = _dY_times(B, hf, get6(ws.dV, k)[0])
        set6(Fq, k, add(yn, zn), add(yf, zf))
        tau[k] = dot6(Jw, Jv, fn, ff)
    for r in range(k0, k0 + nj):
        Jw, Jv = get6(J, r)
        for k in range(k0, k0 + nj):
            M[r, k] = dot6(Jw, Jv, *get6(Fa, k))
            dv[r, k] = dot6(Jw, Jv, *get6(Fv, k))
            dq[r, k] = dot6(Jw, Jv, *get6(Fq, k))
    for k in range(k0, k0 + nj):
        Jw, Jv = get6(J, k)
        cn, cf = cross_force(Jw, Jv, fn, ff)
        xn, xf = get6(Fq, k)
        set6(Fq, k, add(xn, cn), add(xf, cf))
        store3(lv, k, add(rotT(B, Jw), scale(2.0, cross(hf, Jv))))
    _ancestor_blocks(tree, i, ws, dq, dv, M)
    par = tree.parents[i]
    if par >= 0:  # composites: Y, dY and F of the subtree of i into its parent's
        _set_item(ws.mass, par, ws.mass[par] + m)
        store3(ws.h, par, add(load3(ws.h, par), h))
        store33(ws.Io, par, add33(load33(ws.Io, par), Io))
        store33(ws.B, par, add33(load33(ws.B, par), B))
        store3(ws.hf, par, add(load3(ws.hf, par), hf))
        pn, pf = get6(ws.F, par)
        set6(ws.F, par, add(pn, fn), add(pf, ff))


@inline_kernel
def _ancestor_blocks(tree, i, ws, dq, dv, M):
    """The blocks between the coordinates k of body i and those c of each strict ancestor: column k of the
    ancestor rows (J_c^T Fa_k, Fv_k, Fq_k) and row k of the ancestor columns (module docstring)."""
    k0, nj, J, Fa, Fv, Fq, lv = tree.v_idx[i], tree.nv_j[i], ws.J, ws.Fa, ws.Fv, ws.Fq, ws.lv
    a = tree.parents[i]
    while a >= 0:
        for c in range(tree.v_idx[a], tree.v_idx[a] + tree.nv_j[a]):
            Jw, Jv = get6(J, c)
            Aw, Av = get6(ws.dAv, c)
            Qw, Qv = get6(ws.dAq, c)
            Vw = get6(ws.dV, c)[0]
            for k in range(k0, k0 + nj):
                aw, av = get6(Fa, k)
                l = load3(lv, k)
                x = dot6(Jw, Jv, aw, av)
                M[c, k] = x
                M[k, c] = x
                dv[c, k] = dot6(Jw, Jv, *get6(Fv, k))
                dq[c, k] = dot6(Jw, Jv, *get6(Fq, k))
                dv[k, c] = dot6(aw, av, Aw, Av) + dot(l, Jw)
                dq[k, c] = dot6(aw, av, Qw, Qv) + dot(l, Vw)
        a = tree.parents[a]


@inline_kernel
def _rnea_derivatives_terms(tree, q, v, a, gravity, f_ext, ws, dq, dv, M):
    """dtau/dq, dtau/dv and M at (q, v, a) into dq, dv, M (nv, nv), and tau into ws.tau.  Entries between
    coordinates of different branches (neither an ancestor of the other) are zero and written as zero."""
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    for r in range(nv):
        for c in range(nv):
            dq[r, c] = 0.0
            dv[r, c] = 0.0
            M[r, c] = 0.0
    for i in range(nb):
        _forward_step(tree, i, q, v, a, gravity, f_ext, ws)
    for i in range(nb - 1, -1, -1):
        _backward_step(tree, i, ws, ws.tau, dq, dv, M)


@kernel
def _rnea_derivatives_into(tree, q, v, a, gravity, f_ext, ws, dtau_dq, dtau_dv, M):
    """One state into (dtau_dq, dtau_dv, M), each (nv, nv); ``ws`` from :func:`_derivatives_workspace` (or
    :func:`_work_at`); f_ext (nb, 6) [force, torque] in each body's frame, or (0, 6).  ws.tau holds tau."""
    _rnea_derivatives_terms(tree, q, v, a, gravity, f_ext, ws, dtau_dq, dtau_dv, M)


@kernel
def rnea_derivatives_at(tree, q, v, a, gravity, f_ext, dtau_dq, dtau_dv, M):
    """:func:`_rnea_derivatives_into` with a workspace of its own: for compiled callers of one state (the torque
    sources' derivatives), which then compile and link this one kernel instead of inlining the workspace's views."""
    buf, ws = _derivatives_workspace(tree.parents.shape[0], v.shape[0])
    _rnea_derivatives_into(tree, q, v, a, gravity, f_ext, ws, dtau_dq, dtau_dv, M)
    keep_alive(buf)


def inverse_dynamics_derivatives(model, q, v, a, *, gravity=None, f_ext=None):
    """(dtau_dq, dtau_dv, M): the partial derivatives of tau = inverse_dynamics(model, q, v, a) (analytical,
    Carpentier and Mansard 2018; module docstring).

    dtau_dq is taken in the tangent space (nv columns; a floating base's along q (+) dq with dq in its body
    frame, as :func:`dynamics.integrate` and Pinocchio); dtau_da = M(q).  Inputs as
    :func:`dynamics.inverse_dynamics`; each result is (nv, nv), or (B, nv, nv) for a batch.
    """
    if gravity is None and f_ext is None:  # one state: one core call, which checks q, v and a itself
        try:
            out = _core.rnea_derivatives(model.core, q, v, a)
            if out is not None:
                return out
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    checks.check_model(model)
    Q, (V, A), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("a", a, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    out = run(_core.rnea_derivatives_batch, model, Q, V, A, F, g, out=np.empty((B, 3, model.nv, model.nv)))
    if batched:
        return out[:, 0], out[:, 1], out[:, 2]
    return out[0, 0], out[0, 1], out[0, 2]
