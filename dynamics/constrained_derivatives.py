"""Analytical derivatives of constrained forward dynamics (Pinocchio's ``computeConstraintDynamicsDerivatives``,
extended to every constraint of :mod:`dynamics.constraints`: point, weld, hinge and joint coupling).

At the solution (a, lambda) of :func:`dynamics.constrained_forward_dynamics` the KKT conditions hold:

    r1 = ID(q, v, a) - J(q)^T lambda - tau = 0,
    r2 = J a + gamma + 2 alpha J v + beta^2 phi = 0      (Baumgarte's gains alpha, beta; 0, 0 for none).

Differentiating along x = q (tangent space), v, tau with (a, lambda) held in the partials:

    [M  -J^T] [da  ]     [dr1/dx]          dr1/dq = dID/dq - d(J^T lambda)/dq,  dr1/dv = dID/dv,  dr1/dtau = -1
    [J    0 ] [dlam] = - [dr2/dx],         dr2/dq, dr2/dv: the rows' derivatives at fixed a

solved like the dynamics (K = J M^-1 J^T): dlam = K^+ (Z - J M^-1 X), da = M^-1 (X + J^T dlam) with X = -dr1/dx,
Z = -dr2/dx, so that da/dtau = M^-1 - M^-1 J^T K^-1 J M^-1 and dlam/dtau = -K^-1 J M^-1.  dID/dq and dID/dv are
the RNEA derivatives (:mod:`dynamics.rnea_derivatives`) at the constrained a.

The constraint partials are taken in the world frame, on the RNEA derivatives' forward pass (per coordinate j:
J_j, dV_j, dAq_j, dAv_j, :mod:`dynamics.kinematics_derivatives`): a body b's spatial velocity and acceleration
change by dV_j + J_j x ov_b and dAq_j + dV_j x ov_b + J_j x oa_b along q_j, by J_j and dAv_j + J_j x ov_b along
v_j (j on b's support), and a point x on b moves by dx = J_j^v + J_j^w x x.  Hence, with vel = ov^v + ov^w x x
and the classical acceleration acc = oa^v + oa^w x x + ov^w x vel of an anchor:

    d vel = dov^v + dov^w x x + ov^w x dx,    d acc = doa^v + doa^w x x + oa^w x dx + dov^w x vel + ov^w x d vel

* point rows (J a + gamma = acc_A - acc_B, J v = vel_A - vel_B, phi = x_A - x_B): the differences of these;
* weld rows: alpha_A - alpha_B and w_A - w_B, and phi = log(R_A R_B^T), whose derivative is Jl^-1(phi)
  (dth_A - R_A R_B^T dth_B) (Jl the left Jacobian of SO(3)), exact off the manifold too;
* hinge rows t . (alpha_A - alpha_B) + (w_A x t) . (w_A - w_B), t . (w_A - w_B), t . (u_B x u_A), with t and
  u_A turning with body a (dt = J_j^w x t) and u_B with body b;
* coupling rows: linear in q and v (beta^2 and 2 alpha times the row).

The generalised force J^T lambda is the sum over anchors of J_b^T F with F the world spatial force at the origin
(n = x x f + torque, f): f = +-lambda_lin (body a, body b), the weld torque +-lambda_ang, the hinge torque
+-(lambda_4 t_1 + lambda_5 t_2).  Its q derivative at fixed lambda: for k on the support of b,

    d(J_k . F)/dq_j = J_k . dF/dq_j + [j on the support of k's body] F . (J_j x J_k),

dF/dq_j = (dx_j x f, 0) for j on b's support, plus (J_j^w x n_hinge, 0) for j on body a's support (t turns with
body a), J_j x J_k being how moving q_j turns the axis J_k (the tangent-space convention of the RNEA derivatives).

**Redundant rows** (K singular, lambda the minimum-norm multiplier (J^T)^+ (M a + b - tau)): the KKT solve
gives the minimum-norm dlam (K^+ on the right-hand side, as the dynamics), which misses one term of the
derivative of a pseudo-inverse where the dependency of the rows turns with q (a planar loop closed in 3-D on a
floating base: the plane's normal turns with the base): N d(J w)/dq with w = J^+ lambda and N the projector onto
null(J^T) (:func:`_null_space_term`, Golub and Pereyra 1973).  With it, dlam is the derivative of the
minimum-norm lambda wherever the rank of J stays constant nearby (a rank that changes at q has no derivative).
da is unique in every case.

Cost per state: the constrained dynamics, the RNEA derivatives, O(m nv^2) for the constraint partials and
3 nv solves with the factors of M and K (with dependent rows, one more forward pass and O(m^2 nv) for the
null-space term).  A batch runs one compiled kernel per chunk of states.
"""

import numpy as np

from . import checks, rnea_derivatives
from numba import types

from ._numba import PACKED, SingleCall, VECTOR, borrow, copy_into, inline_kernel, keep_alive, kernel
from .checks import DONE, GENERAL, NOT_ARRAYS, _config_ok, _vector_ok
from .constrained_dynamics import (CHOLESKY_RTOL, RANK_RTOL, _C_rows, _cholesky, _constrained_accel_kernel,
                                   _lower_solve, _pinv_solve, _pivoted_cholesky,
                                   _upper_solve, baumgarte_gains)
from .constrained_dynamics import _workspace as kkt_workspace
from .constraints import _anchor_pose, _col, arrays, packed
from .constraints import _unpack as unpack_constraints
from .model import _unpack
from .errors import InputError
from .minverse import Checked, run_checked
from .spatial import add, cross, cross_force, cross_motion, dot, get6, matmul, rot, scale, transpose, _rotation_log

ZERO3 = (0.0, 0.0, 0.0)


@kernel
def _ancestry(tree):
    """anc (nb, nb) int64: anc[i, j] is 1 where body j is i or an ancestor of i, else 0 (int64, not bool, for
    :func:`~dynamics._numba.borrow`); owner (nv,): each coordinate's body."""
    parents, v_idx, nv_j = tree.parents, tree.v_idx, tree.nv_j
    nb, nv = parents.shape[0], tree.S.shape[0]
    anc = np.zeros((nb, nb), np.int64)
    owner = np.empty(nv, np.int64)
    for i in range(nb):
        if parents[i] >= 0:
            for j in range(nb):
                anc[i, j] = anc[parents[i], j]
        anc[i, i] = 1
        for k in range(v_idx[i], v_idx[i] + nv_j[i]):
            owner[k] = i
    return anc, owner


@inline_kernel
def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@inline_kernel
def _point_partials(rws, b, x, j, inside):
    """Along coordinate j (on body b's support when ``inside``, else all zero) for the point x fixed on b:
    (dx/dq, dvel/dq, dacc/dq, dacc/dv, dw/dq, dalpha/dq, dalpha/dv, dw/dv) (module docstring), world axes."""
    if not inside:
        return ZERO3, ZERO3, ZERO3, ZERO3, ZERO3, ZERO3, ZERO3, ZERO3
    Jw, Jv = get6(rws.J, j)
    Vw, Vv = get6(rws.dV, j)
    ow, ol = get6(rws.ov, b)
    aw, al = get6(rws.oa, b)  # oa carries gravity (0, -g): a uniform field, which leaves every derivative alike
    cw, cv = cross_motion(Jw, Jv, ow, ol)
    dvw, dvl = add(Vw, cw), add(Vv, cv)  # d ov_b / dq_j
    Qw, Qv = get6(rws.dAq, j)
    c1w, c1v = cross_motion(Vw, Vv, ow, ol)
    c2w, c2v = cross_motion(Jw, Jv, aw, al)
    daw, dal = add(Qw, add(c1w, c2w)), add(Qv, add(c1v, c2v))  # d oa_b / dq_j
    Aw, Av = get6(rws.dAv, j)
    ew, ev = add(Aw, cw), add(Av, cv)  # d oa_b / dv_j
    vel = add(ol, cross(ow, x))
    dx = add(Jv, cross(Jw, x))
    dvel = add(add(dvl, cross(dvw, x)), cross(ow, dx))
    dacc = add(add(add(dal, cross(daw, x)), cross(aw, dx)), add(cross(dvw, vel), cross(ow, dvel)))
    dacc_v = add(add(ev, cross(ew, x)), add(cross(Jw, vel), cross(ow, dx)))
    return dx, dvel, dacc, dacc_v, dvw, daw, ew, Jw


@inline_kernel
def _jl_inverse(e, y):
    """Jl(e)^-1 y, Jl the left Jacobian of SO(3): y - e x y / 2 + c e x (e x y), c = 1/th^2 - (1 + cos th) /
    (2 th sin th) (-> 1/12 as th -> 0)."""
    th = np.sqrt(dot(e, e))
    c = 1.0 / 12.0 + th * th / 720.0 if th < 1e-4 else 1.0 / (th * th) - (1.0 + np.cos(th)) / (2.0 * th * np.sin(th))
    ey = cross(e, y)
    return add(add(y, scale(-0.5, ey)), scale(c, cross(e, ey)))


@inline_kernel
def _angular_rows(kind, r, j, Ra, Rb, wA, wB, alA, alB, pa, pb, acc, alpha, beta, G, H):
    """Column j of the weld's or hinge's angular rows (r + 3 on) of dr2/dq into G and dr2/dv into H (the
    acceleration rows J a + gamma weighted by acc)."""
    dwq, dalq, dalv = _sub(pa[4], pb[4]), _sub(pa[5], pb[5]), _sub(pa[6], pb[6])
    dA, dB = pa[7], pb[7]  # J_j^w on each side's support, else zero
    ddw_v = _sub(dA, dB)
    if kind == 1:
        R = matmul(Ra, transpose(Rb))
        dphi = _jl_inverse(_rotation_log(R), _sub(dA, rot(R, dB)))
        for t in range(3):
            G[r + 3 + t, j] += acc * dalq[t] + 2.0 * alpha * dwq[t] + beta * beta * dphi[t]
            H[r + 3 + t, j] += acc * dalv[t] + 2.0 * alpha * ddw_v[t]
        return
    uA, uB = _col(Ra, 2), _col(Rb, 2)
    n, dn = cross(uB, uA), add(cross(cross(dB, uB), uA), cross(uB, cross(dA, uA)))
    dw, dal = _sub(wA, wB), _sub(alA, alB)
    for s in range(2):
        tk = _col(Ra, s)
        dt = cross(dA, tk)
        wt = cross(wA, tk)
        G[r + 3 + s, j] += (acc * (dot(dt, dal) + dot(tk, dalq) + dot(add(cross(pa[4], tk), cross(wA, dt)), dw)
                                   + dot(wt, dwq)) + 2.0 * alpha * (dot(dt, dw) + dot(tk, dwq))
                            + beta * beta * (dot(dt, n) + dot(tk, dn)))
        H[r + 3 + s, j] += (acc * (dot(tk, dalv) + dot(cross(dA, tk), dw) + dot(wt, ddw_v))
                            + 2.0 * alpha * dot(tk, ddw_v))


@inline_kernel
def _body_w(X, b):
    """The angular part of row b of X (nb, 6), zero for the world (b = -1)."""
    if b < 0:
        return ZERO3
    return get6(X, b)[0]


@kernel
def _row_partials(tree, C, rws, anc, owner, acc, alpha, beta, G, H):
    """G = dr2/dq and H = dr2/dv (m, nv) at fixed a, from the RNEA derivatives' forward pass ``rws`` at (q, v, a)
    (module docstring); acc = 0 leaves out J a + gamma (acc = 0, alpha = 1/2, beta = 0: d(J v)/dq in G)."""
    nv = G.shape[1]
    G[:, :] = 0.0
    H[:, :] = 0.0
    for c in range(C.kind.shape[0]):
        kind, r = C.kind[c], C.row[c]
        if kind == 3:  # coupling: q_f - k q_l - offset, linear
            vf, vl, k = C.idx[c, 1], C.idx[c, 3], C.coef[c, 0]
            G[r, vf] += beta * beta
            G[r, vl] -= beta * beta * k
            H[r, vf] += 2.0 * alpha
            H[r, vl] -= 2.0 * alpha * k
            continue
        ba, bb = C.body[c, 0], C.body[c, 1]
        Ra, xa = _anchor_pose(C, c, 0, rws.oR, rws.op)
        Rb, xb = _anchor_pose(C, c, 1, rws.oR, rws.op)
        wA, wB, alA, alB = _body_w(rws.ov, ba), _body_w(rws.ov, bb), _body_w(rws.oa, ba), _body_w(rws.oa, bb)
        for j in range(nv):
            ina, inb = ba >= 0 and anc[ba, owner[j]] != 0, bb >= 0 and anc[bb, owner[j]] != 0
            if not (ina or inb):
                continue
            pa, pb = _point_partials(rws, ba, xa, j, ina), _point_partials(rws, bb, xb, j, inb)
            dx, dvel, dacc, dacc_v = _sub(pa[0], pb[0]), _sub(pa[1], pb[1]), _sub(pa[2], pb[2]), _sub(pa[3], pb[3])
            for t in range(3):
                G[r + t, j] += acc * dacc[t] + 2.0 * alpha * dvel[t] + beta * beta * dx[t]
                H[r + t, j] += acc * dacc_v[t] + 2.0 * alpha * dx[t]
            if kind != 0:
                _angular_rows(kind, r, j, Ra, Rb, wA, wB, alA, alB, pa, pb, acc, alpha, beta, G, H)


@kernel
def _force_partials(tree, C, rws, anc, owner, lam, P):
    """P = d(J^T lambda)/dq (nv, nv) at fixed lambda (module docstring)."""
    nv = P.shape[0]
    P[:, :] = 0.0
    for c in range(C.kind.shape[0]):
        kind, r = C.kind[c], C.row[c]
        if kind == 3:  # a coupling's J is constant
            continue
        ba = C.body[c, 0]
        Ra, _ = _anchor_pose(C, c, 0, rws.oR, rws.op)
        f = (lam[r], lam[r + 1], lam[r + 2])
        tq = ZERO3
        if kind == 1:
            tq = (lam[r + 3], lam[r + 4], lam[r + 5])
        elif kind == 2:
            tq = add(scale(lam[r + 3], _col(Ra, 0)), scale(lam[r + 4], _col(Ra, 1)))
        for s in range(2):
            b = C.body[c, s]
            if b < 0:
                continue
            _, x = _anchor_pose(C, c, s, rws.oR, rws.op)
            sign = 1.0 if s == 0 else -1.0
            Fn, Ff = scale(sign, add(cross(x, f), tq)), scale(sign, f)
            for j in range(nv):
                inb, ina = anc[b, owner[j]] != 0, kind == 2 and ba >= 0 and anc[ba, owner[j]] != 0
                if not (inb or ina):  # F does not change along q_j, nor does any J_k of b's support
                    continue
                Jw, Jv = get6(rws.J, j)
                dn = cross(add(Jv, cross(Jw, x)), f) if inb else ZERO3
                if ina:
                    dn = add(dn, cross(Jw, tq))
                dn = scale(sign, dn)
                # F . (J_j x J_k) = -J_k . (J_j x* F)
                Hn, Hf = cross_force(Jw, Jv, Fn, Ff)
                for k in range(nv):
                    if anc[b, owner[k]] == 0:
                        continue
                    Kw, Kv = get6(rws.J, k)
                    y = dot(Kw, dn)
                    if inb and anc[owner[k], owner[j]] != 0:  # q_j turns the axis J_k: J_j x J_k
                        y -= dot(Kw, Hn) + dot(Kv, Hf)
                    P[k, j] += y


@inline_kernel
def _solve_t(L, lam, w):
    """w = L^-T w in place: :func:`dynamics.constrained_dynamics._ltl_solve_t` inlined (called per column, the
    call cost more than its loop at small nv)."""
    for i in range(w.shape[0] - 1, -1, -1):
        w[i] /= L[i, i]
        j = lam[i]
        while j >= 0:
            w[j] -= L[i, j] * w[i]
            j = lam[j]


@inline_kernel
def _solve(L, lam, w):
    """w = L^-1 w in place: :func:`dynamics.constrained_dynamics._ltl_solve` inlined."""
    for i in range(w.shape[0]):
        y = w[i]
        j = lam[i]
        while j >= 0:
            y -= L[i, j] * w[j]
            j = lam[j]
        w[i] = y / L[i, i]


@kernel
def _kkt_columns(kws, K, Kinv, YT, XT, RT, x):
    """Each row c of XT (nv,) and RT (m,) holds a column of X and Z (module docstring); replaced by the
    column of da and of dlam: dlam = K^+ (Z - J M^-1 X), da = M^-1 (X + J^T dlam), M^-1 = L^-1 L^-T and
    J M^-1 = Y^T L^-T from the dynamics' factors in ``kws``.  The products run as axpy loops over contiguous
    rows (Y^T in YT, K^-1 formed once when K is regular): reductions do not vectorise without fastmath, and
    were 4x slower here."""
    LM, Y, LK, dof_parents, piv, t = kws[3], kws[8], kws[12], kws[13], kws[14], kws[15]
    m, nv = Y.shape[0], Y.shape[1]
    _gram(Y, K)
    dmax = 0.0
    for r in range(m):
        copy_into(LK[r], K[r])
        dmax = max(dmax, K[r, r])
        for k in range(nv):
            YT[k, r] = Y[r, k]
    full = dmax > 0.0 and _cholesky(LK, m, CHOLESKY_RTOL * dmax)
    if full:  # K^-1 row by row (symmetric)
        for r in range(m):
            for s in range(m):
                Kinv[r, s] = 1.0 if r == s else 0.0
            _lower_solve(LK, m, Kinv[r])
            _upper_solve(LK, m, Kinv[r])
    for c in range(XT.shape[0]):
        w, z = XT[c], RT[c]
        _solve_t(LM, dof_parents, w)
        copy_into(x, z)
        for k in range(nv):  # x = z - Y w
            wk = w[k]
            if wk != 0.0:
                for r in range(m):
                    x[r] -= YT[k, r] * wk
        if full:
            for r in range(m):
                z[r] = 0.0
            for r in range(m):
                xr = x[r]
                for s in range(m):
                    z[s] += Kinv[r, s] * xr
        else:  # the dynamics' minimum-norm solve (it overwrites K: rebuilt each time)
            _gram(Y, K)
            _pinv_solve(K, x, RANK_RTOL, z, LK, piv, t)
        for r in range(m):  # w += Y^T z
            zr = z[r]
            for k in range(nv):
                w[k] += Y[r, k] * zr
        _solve(LM, dof_parents, w)
    return full


@kernel
def _gram(Y, K):
    """K = Y Y^T (m, m)."""
    m, nv = Y.shape[0], Y.shape[1]
    for r in range(m):
        for s in range(r, m):
            y = 0.0
            for k in range(nv):
                y += Y[r, k] * Y[s, k]
            K[r, s] = y
            K[s, r] = y


@kernel
def _null_space_term(tree, C, q, J, lam, rws, anc, owner, no_forces, null, G, H, RT):
    """Rows 0..nv-1 of RT (dlam along each q_j) += N d(J w)/dq_j with w = J^+ lam and N the projector onto
    null(J^T): the part of the derivative of the minimum-norm lam = (J^T)^+ (M a + b - tau) that the minimum-norm
    KKT solve leaves out when rows are dependent, d(A^+) g = ... + (1 - A^+ A) dA^T A^+T A^+ g with A = J^T
    (Golub and Pereyra 1973); zero where the dependency does not turn with q.  N = 1 - Q Q^T with Q an
    orthonormal basis of range(J J^T) = B R^-T, J J^T = B B^T (Cholesky with diagonal pivoting), R R^T = B^T B.
    ``null`` = (JJ, L, Gm, Q (m, m), piv (m,) int, s, t (m,), w, zero (nv,), zero3 (3,)).  Overwrites rws."""
    JJ, L, Gm, Q, piv, s, t, w, zero, zero3 = null
    m, nv = J.shape[0], J.shape[1]
    dmax = 0.0
    for r in range(m):
        for c in range(m):
            y = 0.0
            for k in range(nv):
                y += J[r, k] * J[c, k]
            JJ[r, c] = y
            Q[r, c] = y
        dmax = max(dmax, JJ[r, r])
    _pinv_solve(Q, lam, RANK_RTOL, s, L, piv, t)  # J J^T s = lam (lam lies in J's range); Q as scratch
    for k in range(nv):  # w = J^T s = J^+ lam
        y = 0.0
        for r in range(m):
            y += J[r, k] * s[r]
        w[k] = y
        zero[k] = 0.0
    rank = _pivoted_cholesky(JJ, RANK_RTOL * dmax, L, piv)  # B[piv[i]] = L[i, :rank]
    for a in range(rank):
        for b in range(a + 1):
            y = 0.0
            for r in range(m):
                y += L[r, a] * L[r, b]
            Gm[a, b] = y
    _cholesky(Gm, rank, 0.0)
    for i in range(m):  # row piv[i] of Q = R^-1 (row i of L)
        for a in range(rank):
            t[a] = L[i, a]
        _lower_solve(Gm, rank, t)
        for a in range(rank):
            Q[piv[i], a] = t[a]
    for i in range(tree.parents.shape[0]):  # the kinematics at velocity w (acceleration and gravity zero)
        rnea_derivatives._forward_step(tree, i, q, w, zero, zero3, no_forces, rws)
    _row_partials(tree, C, rws, anc, owner, 0.0, 0.5, 0.0, G, H)  # G = d(J w)/dq
    for j in range(nv):  # RT[j] += G[:, j] - Q Q^T G[:, j]
        for a in range(rank):
            y = 0.0
            for r in range(m):
                y += Q[r, a] * G[r, j]
            t[a] = y
        for r in range(m):
            y = G[r, j]
            for a in range(rank):
                y -= Q[r, a] * t[a]
            RT[j, r] += y


@kernel
def _state_derivatives(tree, C, gravity, q, v, tau, alpha, beta, work, out):
    """One state into out (3, nv + m, nv): [da; dlam] along q, v, tau.  Returns -1, or the body whose joint
    makes M singular."""
    kws, rws, dq, dv, M, G, H, P, XT, RT, K, Kinv, YT, x, a, lam, anc, owner, null = work
    nv, m = a.shape[0], lam.shape[0]
    status = _constrained_accel_kernel(tree, C, gravity, q, v, tau, alpha, beta, kws, a, lam)
    if status >= 0:
        return status
    rnea_derivatives._rnea_derivatives_terms(tree, q, v, a, gravity, kws[11], rws, dq, dv, M)
    _row_partials(tree, C, rws, anc, owner, 1.0, alpha, beta, G, H)
    _force_partials(tree, C, rws, anc, owner, lam, P)
    for c in range(nv):  # X = -dr1/dx, Z = -dr2/dx, column by column (rows of XT, RT)
        for k in range(nv):
            XT[c, k] = P[k, c] - dq[k, c]
            XT[nv + c, k] = -dv[k, c]
            XT[2 * nv + c, k] = 1.0 if k == c else 0.0
        for r in range(m):
            RT[c, r] = -G[r, c]
            RT[nv + c, r] = -H[r, c]
            RT[2 * nv + c, r] = 0.0
    if not _kkt_columns(kws, K, Kinv, YT, XT, RT, x):  # dependent rows
        _null_space_term(tree, C, q, kws[4], lam, rws, anc, owner, kws[11], null, G, H, RT)
    for c in range(3 * nv):
        i, j = c // nv, c % nv
        for k in range(nv):
            out[i, k, j] = XT[c, k]
        for r in range(m):
            out[i, nv + r, j] = RT[c, r]
    return -1


@kernel
def _work(tree, m):
    """(buffer, work) of one thread for :func:`_state_derivatives`: the dynamics' workspace, the RNEA derivatives'
    (carved from the buffer: keep it alive), then dtau/dq, dtau/dv, M, G, H, P, XT, RT, K, K^-1, Y^T, x, a, lam
    and the tree's ancestry."""
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    buf, rws = rnea_derivatives._derivatives_workspace(nb, nv)
    anc, owner = _ancestry(tree)
    work = (kkt_workspace(nb, nv, m), rws, np.empty((nv, nv)), np.empty((nv, nv)), np.empty((nv, nv)),
            np.empty((m, nv)), np.empty((m, nv)), np.empty((nv, nv)), np.empty((3 * nv, nv)), np.empty((3 * nv, m)),
            np.empty((m, m)), np.empty((m, m)), np.empty((nv, m)), np.empty(m), np.empty(nv), np.empty(m), anc, owner,
            (np.empty((m, m)), np.empty((m, m)), np.empty((m, m)), np.empty((m, m)), np.empty(m, np.int64),
             np.empty(m), np.empty(m), np.empty(nv), np.empty(nv), np.zeros(3)))
    return buf, work


@kernel
def _derivatives_batch(tree, Q, V, T, C, gravity, alpha, beta, out, status):
    """out[b] = [da; dlam] along q, v, tau at the rows of Q, V, T (V, T may have one row)."""
    # borrowed (no reference counts), which also gives the tree and C the single call's types: one compiled
    # _state_derivatives serves both
    t, c, q, v, tau, o = borrow(tree), borrow(C), borrow(Q), borrow(V), borrow(T), borrow(out)
    buf, owned = _work(t, out.shape[2] - tree.S.shape[0])
    work = borrow(owned)
    lv, lt = V.shape[0] - 1, T.shape[0] - 1
    for b in range(Q.shape[0]):
        status[b] = _state_derivatives(t, c, gravity, q[b], v[min(b, lv)], tau[min(b, lt)], alpha, beta, work, o[b])
    keep_alive(buf)
    keep_alive(owned)
    keep_alive(tree)
    keep_alive(C)
    keep_alive(Q)
    keep_alive(V)
    keep_alive(T)
    keep_alive(out)


def _derivatives_one(packed, packed_C, q, v, tau, alpha, beta, out):
    """One state from Python into out (3, nv + m, nv), inputs checked in the same compiled call: DONE, or
    GENERAL for a bad input or a singular M (the general path then says which)."""
    tree, gravity, nq = _unpack(packed)
    C = unpack_constraints(packed_C)
    nv = tree.S.shape[0]
    m = out.shape[1] - nv
    if not (_config_ok(tree, nq, q) and _vector_ok(v, nv) and _vector_ok(tau, nv) and out.shape[2] == nv
            and m == _C_rows(C)):
        return GENERAL
    g = np.empty(3)  # gravity as a writable array: the batch's type
    g[0], g[1], g[2] = gravity[0], gravity[1], gravity[2]
    buf, owned = _work(tree, m)
    status = _state_derivatives(tree, C, g, q, v, tau, alpha, beta, borrow(owned), out)
    keep_alive(buf)
    keep_alive(owned)
    return DONE if status < 0 else GENERAL


_checked = Checked(_derivatives_batch)
_single = SingleCall(_derivatives_one, PACKED, VECTOR, VECTOR, VECTOR, types.float64, types.float64,
                     types.float64[:, :, ::1])


def constrained_forward_dynamics_derivatives(model, q, v, tau, *, baumgarte=None, gravity=None):
    """(da_dq, da_dv, da_dtau, dlam_dq, dlam_dv, dlam_dtau): the partial derivatives of
    ``a, lam = constrained_forward_dynamics(model, q, v, tau, baumgarte=..., gravity=...)`` (analytical, module
    docstring), as Pinocchio's computeConstraintDynamicsDerivatives (ddq_dq, ddq_dv, ddq_dtau, dlambda_dq,
    dlambda_dv, dlambda_dtau).

    q derivatives are in the tangent space (nv columns, as :func:`inverse_dynamics_derivatives`).  The a blocks
    are (nv, nv), the lam blocks (m, nv), with a leading B for a batch; lam's rows are those of
    :mod:`dynamics.constraints` (world axes).  Redundant rows: dlam is the derivative of the minimum-norm lam
    where the rank of the rows stays constant nearby (module docstring).
    Raises InputError on a model without constraints, for bad inputs (naming the argument) and when M is
    singular (naming the joint).
    """
    alpha, beta = baumgarte_gains(baumgarte)
    try:  # one state: one compiled call that checks q, v and tau itself
        if gravity is None and model.constraints:
            nv, m = model.nv, arrays(model)[1]
            out = np.empty((3, nv + m, nv))
            if _single.call(model.packed, packed(model), q, v, tau, alpha, beta, out) == DONE:
                a, lam = out[:, :nv], out[:, nv:]
                return a[0], a[1], a[2], lam[0], lam[1], lam[2]
    except NOT_ARRAYS:  # not a model, or arrays of other types: the general path says what is wrong or converts
        pass
    checks.check_model(model)
    C, m = arrays(model)
    if m == 0:
        raise InputError("model: has no constraints; constrained_forward_dynamics_derivatives differentiates the "
                         "dynamics of a model with constraints (dynamics.with_constraints); for an open tree use "
                         "forward_dynamics_derivatives")
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    g = checks.gravity_vector(model, gravity)
    nv = model.nv
    out = np.empty((B, 3, nv + m, nv))
    run_checked(model, _checked, (Q, V, T), (C, g, alpha, beta), out, "constrained forward dynamics derivatives")
    if not batched:
        out = out[0]
    a, lam = out[..., :nv, :], out[..., nv:, :]
    i = (slice(None),) if batched else ()
    return (a[i + (0,)], a[i + (1,)], a[i + (2,)], lam[i + (0,)], lam[i + (1,)], lam[i + (2,)])
