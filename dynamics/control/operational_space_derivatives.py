"""Analytical state derivatives of the operational-space controller (:mod:`.operational_space`), for a fixed base
of 1-dof joints (nq = nv, as the controller's other users; other models return False and are differenced).

The torque is (*) of :mod:`.operational_space`, with F = Lambda y the task force and u = J^T F:

    tau = ID(q, v, 0) + tau_p - tau_passive + J^T F,          A = J M^-1 J^T + d 1,   Lambda = A^-1,
    y = xdd_d + Kd (xd_d - J v) + Kp e - Jdot v - J M^-1 tau_p,   tau_p = Kp0 (q_0 - q) - Kd0 v.

Differentiating (dLambda = -Lambda dA Lambda, dM^-1 = -M^-1 dM M^-1) and collecting, with s = M^-1 (u + tau_p):

    dtau/dv = dID/dv - Kd0 - dtau_passive/dv + J^T Lambda (-Kd J - d(Jdot v)/dv + J M^-1 Kd0)
    dtau/dq_m = dID/dq_m + Kp0 e_m' - dtau_passive/dq_m + G_m + J^T Lambda X_m,
    X_m = -Kd dJ_m v + Kp de/dq_m - d(Jdot v)/dq_m - dJ_m s + J M^-1 (dM_m s - G_m + Kp0 e_m)

where dJ_m = dJ/dq_m, G_m = dJ_m^T F (the Jacobian's transpose moved at fixed F), dM_m s = d(M s)/dq_m the RNEA's
q derivative at (q, 0, s) without gravity (:mod:`dynamics.rnea_derivatives`), and e_m the m-th unit vector.
The rows are the task's rows (r <= 6); Kd, Kp the task gains.

The frame's kinematics (Featherstone 2008, ch. 2, in the world frame at the world origin): joint j's axis S_j =
(w_j, v_j) follows from the frame Jacobian at the frame origin p ("local_world_aligned": [J^v; J^w] with J^v_j =
v_j + w_j x p), and moving an ancestor m (m <= j along the frame's path) moves it by dS_j/dq_m = S_m x S_j.  With
V_{<m}, V_{>=m} the sums of S_j v_j over the path before m and from m on, and T_m = sum_{k >= m} v_k S_k x V_{>k}:

    dJ_j/dq_m = ([m <= j] S_m x S_j  at p) + w_j x J^v_m in the linear rows   (p moves by J^v_m)
    Jdot v    = A at p (classical):  (A^v + A^w x p + w x v_p,  A^w),  A = T_0,  v_p = J^v v
    dA/dq_m   = S_m x T_m + V_{<m} x (S_m x V_{>=m}),     dA/dv_m = S_m x (V_{>=m} - V_{<m})

(the first by the Jacobi identity of the motion cross product).  de/dq_m: -J^v_m for the position rows and
-Jr(e_o)^-1 w_m for the orientation error e_o = log(R_d R^T) (R moves as Exp(w_m dq) R).  Every sum is over the
frame's path, in the order of the coordinates (an ancestor's coordinate comes first); off the path J is zero and
so is every term.  Cost: two RNEA derivatives and O(r nv^2) more, against 4 nv controller evaluations by
central differences.
"""

import numpy as np

from .._numba import kernel
from ..joints import _so3_jr_inv
from ..rnea_derivatives import rnea_derivatives_at
from ..spatial import _rotation_log, add, cross, cross_motion, get6, matmul, transpose
from .operational_space import operational_space_into, orientation_at, task_reference_at
from .passive import passive_derivatives, passive_torques


@kernel
def _axes(J, p, Sw):
    """Sw[j] = (w_j, v_j): joint j's axis in the world frame at the world origin, from J at the frame origin p."""
    for j in range(J.shape[1]):
        w = (J[3, j], J[4, j], J[5, j])
        vo = cross(p, w)  # v_j = J^v_j - w_j x p = J^v_j + p x w_j
        Sw[j, 0], Sw[j, 1], Sw[j, 2] = w
        Sw[j, 3], Sw[j, 4], Sw[j, 5] = J[0, j] + vo[0], J[1, j] + vo[1], J[2, j] + vo[2]


@kernel
def _sums(Sw, u, pre, suf):
    """pre[m] = sum_{j < m} u_j S_j, suf[m] = sum_{j >= m} u_j S_j."""
    nv = u.shape[0]
    acc = np.zeros(6)
    for m in range(nv):
        pre[m] = acc
        acc += u[m] * Sw[m]
    acc[:] = 0.0
    for m in range(nv - 1, -1, -1):
        acc += u[m] * Sw[m]
        suf[m] = acc


@kernel
def _jacobian_derivative_times(Sw, J, p, u, pre, suf, out):
    """out[:, m] = (dJ/dq_m) u (6, nv), J at p in world axes (module docstring)."""
    _sums(Sw, u, pre, suf)
    wu = (suf[0, 0], suf[0, 1], suf[0, 2])  # sum_j w_j u_j
    for m in range(u.shape[0]):
        sw, sv = get6(Sw, m)
        uw, uv = get6(suf, m)
        dw, dv = cross_motion(sw, sv, uw, uv)
        lin = add(add(dv, cross(dw, p)), cross(wu, (J[0, m], J[1, m], J[2, m])))
        out[0, m], out[1, m], out[2, m] = lin
        out[3, m], out[4, m], out[5, m] = dw


@kernel
def _jacobian_transpose_derivative(Sw, J, p, rows, F, G):
    """G[j, m] = sum_a F_a dJ[rows[a], j]/dq_m: d(J^T F)/dq at fixed F (module docstring)."""
    f = np.zeros(6)
    for a in range(rows.shape[0]):
        f[rows[a]] += F[a]
    flin, fang = (f[0], f[1], f[2]), (f[3], f[4], f[5])
    n_o = add(fang, cross(p, flin))  # the task force at the world origin
    nv = J.shape[1]
    for j in range(nv):
        wj, vj = get6(Sw, j)
        for m in range(nv):
            c = cross(wj, (J[0, m], J[1, m], J[2, m]))
            x = flin[0] * c[0] + flin[1] * c[1] + flin[2] * c[2]
            if m <= j:
                sw, sv = get6(Sw, m)
                dw, dv = cross_motion(sw, sv, wj, vj)
                x += dw[0] * n_o[0] + dw[1] * n_o[1] + dw[2] * n_o[2] + dv[0] * flin[0] + dv[1] * flin[1] \
                    + dv[2] * flin[2]
            G[j, m] = x


@kernel
def _bias_derivatives(Sw, J, p, v, pre, suf, T, Bq, Bv):
    """Bq = d(Jdot v)/dq, Bv = d(Jdot v)/dv (6, nv), Jdot v the frame's classical acceleration at a = 0 at p in
    world axes (module docstring)."""
    nv = v.shape[0]
    _sums(Sw, v, pre, suf)
    acc = np.zeros(6)
    for m in range(nv - 1, -1, -1):  # T_m = sum_{k >= m} v_k S_k x V_{>k}
        nxt = suf[m + 1] if m + 1 < nv else np.zeros(6)
        sw, sv = get6(Sw, m)
        cw, cv = cross_motion(sw, sv, (nxt[0], nxt[1], nxt[2]), (nxt[3], nxt[4], nxt[5]))
        acc[0], acc[1], acc[2] = acc[0] + v[m] * cw[0], acc[1] + v[m] * cw[1], acc[2] + v[m] * cw[2]
        acc[3], acc[4], acc[5] = acc[3] + v[m] * cv[0], acc[4] + v[m] * cv[1], acc[5] + v[m] * cv[2]
        T[m] = acc
    w, vo = get6(suf, 0)
    aw = (T[0, 0], T[0, 1], T[0, 2])
    vp = add(vo, cross(w, p))
    for m in range(nv):
        sw, sv = get6(Sw, m)
        dp = (J[0, m], J[1, m], J[2, m])
        up, lo = get6(suf, m), get6(pre, m)
        dVw, dVv = cross_motion(sw, sv, up[0], up[1])  # dV/dq_m
        dvp = add(add(dVv, cross(dVw, p)), cross(w, dp))
        tw, tv = get6(T, m)
        t1w, t1v = cross_motion(sw, sv, tw, tv)
        t2w, t2v = cross_motion(lo[0], lo[1], dVw, dVv)
        dAw, dAv = add(t1w, t2w), add(t1v, t2v)
        lin = add(add(add(dAv, cross(dAw, p)), cross(aw, dp)), add(cross(dVw, vp), cross(w, dvp)))
        Bq[0, m], Bq[1, m], Bq[2, m] = lin
        Bq[3, m], Bq[4, m], Bq[5, m] = dAw
        ew, ev = cross_motion(sw, sv, (up[0][0] - lo[0][0], up[0][1] - lo[0][1], up[0][2] - lo[0][2]),
                              (up[1][0] - lo[1][0], up[1][1] - lo[1][1], up[1][2] - lo[1][2]))
        lin = add(add(ev, cross(ew, p)), add(cross(sw, vp), cross(w, dp)))
        Bv[0, m], Bv[1, m], Bv[2, m] = lin
        Bv[3, m], Bv[4, m], Bv[5, m] = ew


@kernel
def _orientation_rows(src, t, R, Jw, Dw):
    """Dw (3, nv) = d e_o/dq = -Jr(e_o)^-1 w_m for the orientation error e_o = log(R_d R^T), Jw = J's angular
    rows (module docstring)."""
    Rd, wd = orientation_at(src.times, src.orientation, t)
    e = _rotation_log(matmul(Rd, transpose(R)))
    c = _so3_jr_inv(e[0], e[1], e[2])
    n2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2]
    P = ((0.0, -e[2], e[1]), (e[2], 0.0, -e[0]), (-e[1], e[0], 0.0))
    for r in range(3):
        for s in range(3):
            x = 0.5 * P[r][s] + c * e[r] * e[s] + ((1.0 - c * n2) if r == s else 0.0)
            for m in range(Jw.shape[1]):
                Dw[r, m] -= x * Jw[s, m]


def operational_space_derivatives(tag, src, tree, ps, t, q, v, ws, dq, dv):
    """dq = dtau/dq, dv = dtau/dv (nv, nv) of the operational-space torque at (t, q, v) (module docstring);
    returns False (nothing written) unless every joint is 1-dof (nq = nv).  NaN where the torque is NaN (a
    singular task or M).  Arguments as :func:`dynamics.control.dispatch.torque_eval`'s; compiled as
    :func:`dynamics.control.derivatives.source_derivatives_into` for this kind (not a kernel of its own: one
    compiled layer fewer)."""
    nv = v.shape[0]
    if q.shape[0] != nv:
        return False
    x_ref, tau = np.empty((3, 3)), np.empty(nv)
    task_reference_at(src, t, x_ref)
    pas = ws[1][3]
    passive_torques(ps, q, v, pas)
    R, p = operational_space_into(src, tree, ps.gravity, ps.f_ext, t, q, v, x_ref, pas, ws[0], tau)
    if not np.all(np.isfinite(tau)):
        dq[:, :], dv[:, :] = np.nan, np.nan
        return True
    J, Minv, tp, Lam = src.ws[3], src.ws[7], src.ws[9], src.ws[14][0]
    rows = src.rows
    r = rows.shape[0]
    F, s = np.zeros(r), np.zeros(nv)  # F = Lambda y, s = M^-1 (J^T F + tau_p)
    for a in range(r):
        for b in range(r):
            F[a] += Lam[a, b] * src.ws[12][b]
    u = tp.copy()
    for c in range(nv):
        for a in range(r):
            u[c] += J[rows[a], c] * F[a]
    for c in range(nv):
        for k in range(nv):
            s[c] += Minv[c, k] * u[k]
    # the inverse dynamics at a = 0 into (dq, dv), and d(M s)/dq without gravity into DM
    M, DM, scratch = np.empty((nv, nv)), np.empty((nv, nv)), np.empty((nv, nv))
    rnea_derivatives_at(tree, q, v, np.zeros(nv), ps.gravity, ps.f_ext, dq, dv, M)
    rnea_derivatives_at(tree, q, np.zeros(nv), s, np.zeros(3), np.zeros((0, 6)), DM, scratch, M)
    # the frame's kinematic derivatives
    K = np.empty((4, nv, 6))  # Sw, pre, suf, T
    D = np.zeros((5, 6, nv))  # dJ v, dJ s, d(Jdot v)/dq, d(Jdot v)/dv, de/dq
    G = np.empty((nv, nv))
    _axes(J, p, K[0])
    _jacobian_derivative_times(K[0], J, p, v, K[1], K[2], D[0])
    _jacobian_derivative_times(K[0], J, p, s, K[1], K[2], D[1])
    _jacobian_transpose_derivative(K[0], J, p, rows, F, G)
    _bias_derivatives(K[0], J, p, v, K[1], K[2], K[3], D[2], D[3])
    for m in range(nv):
        D[4, 0, m], D[4, 1, m], D[4, 2, m] = -J[0, m], -J[1, m], -J[2, m]
    _orientation_rows(src, t, R, J[3:], D[4, 3:])
    _assemble(src, ps, q, v, ws, D, DM, G, dq, dv)
    return True


@kernel
def _assemble(src, ps, q, v, ws, D, DM, G, dq, dv):
    """dq += G + J^T Lambda X - Kp0 - dtau_passive/dq, dv += J^T Lambda Y - Kd0 - dtau_passive/dv, with X = dy/dq
    - dA F and Y = dy/dv of the module docstring; (dq, dv) hold the inverse dynamics' derivatives at a = 0."""
    nv = v.shape[0]
    J, JM, Lam, rows, kt, kp0, kd0 = src.ws[3], src.ws[11], src.ws[14][0], src.rows, src.task_gains, src.gains[0], \
        src.gains[1]
    r = rows.shape[0]
    inner = DM - G
    for c in range(nv):
        inner[c, c] += kp0[c]
    X, Y = np.empty((r, nv)), np.empty((r, nv))
    for a in range(r):
        k = rows[a]
        for m in range(nv):
            x = -kt[1, k] * D[0, k, m] + kt[0, k] * D[4, k, m] - D[2, k, m] - D[1, k, m]
            for c in range(nv):
                x += JM[a, c] * inner[c, m]
            X[a, m] = x
            Y[a, m] = -kt[1, k] * J[k, m] - D[3, k, m] + JM[a, m] * kd0[m]
    for c in range(nv):
        for a in range(r):
            g = 0.0  # (J^T Lambda)[c, a]
            for b in range(r):
                g += J[rows[b], c] * Lam[b, a]
            for m in range(nv):
                dq[c, m] += g * X[a, m]
                dv[c, m] += g * Y[a, m]
    pq, pv = ws[1][0], ws[1][1]
    passive_derivatives(ps, q, v, pq, pv)
    for c in range(nv):
        for m in range(nv):
            dq[c, m] += G[c, m]
        dq[c, c] -= kp0[c] + pq[c]
        dv[c, c] -= kd0[c] + pv[c]
