"""Derivatives of the generalised contact force tau_c = sum_k A_k^T F_k (:mod:`.forces`) for the simulation's
Jacobian (:mod:`dynamics.simulation.jacobian`), from the contacts an evaluation found.

For contact k (world point P, unit normal n from b to a, penetration x, the pair's material), A_k (3 x nv) is the
Jacobian of the relative velocity of the two bodies' material points at P, v_rel = A_k v:

    A_k[:, j] = R_i S_j^v + (R_i S_j^w) x (P - o_i)      for every dof j of every ancestor i of body a,
                (minus the same over body b's ancestors)     (R_i, o_i): body i's world pose; S_j = (S^w, S^v)

and F_k = f_n n + f_t depends on the state through x and v_rel only.  Hence, with G_k = dF_k/dv_rel (3 x 3) and
F_x = dF_k/dx (3,):

    d tau_c / dv = sum_k A_k^T G_k A_k                   exact (P, n and x depend on q alone)
    d tau_c / dq ~ -sum_k A_k^T F_x (n^T A_k)            the contact's stiffness: dx/dq = -n^T A_k (the first-order
                                                         change of a penetration is the approach of the two
                                                         material points along the normal)

The q-part leaves out how A_k, n and v_rel at fixed v turn with q (the geometric terms, of the order of |F| times a
curvature, against the stiffness k of the law): what Radau's Newton iteration needs, whose convergence test
accepts any matrix close enough.  A run that integrates sensitivities needs the exact d tau_c/dq and differences
it (:func:`dynamics.simulation.jacobian.contact_terms`).

G and F_x from the law of :mod:`.forces` (s = |v_t| / v_s, c(|v_t|) = mu(s) / |v_t|, so that f_t = -c f_n v_t;
P_t = 1 - n n^T):

    d f_n / d v_rel = -k x d n      while 1 - d v_n > 0 (else 0),     d f_n / dx = k (1 - d v_n)_+
    d f_t / d v_rel = -f_n (c P_t + c'(|v_t|) v_t v_t^T / |v_t|) - c v_t (d f_n / d v_rel)^T
    G = n (d f_n / d v_rel)^T + d f_t / d v_rel,      F_x = (d f_n / dx) (n - c v_t)
"""

import numpy as np

from .._numba import inline_kernel, kernel
from ..spatial import cross, dot, load3, load33, rot
from .forces import K_DISS, K_MU_D, K_MU_S, K_STIFF, K_VS, friction_coefficient, friction_ratio


@inline_kernel
def point_jacobian(tree, oR, op, body, P, sign, A):
    """A[:, j] += sign * the world velocity of body's material point at the world point P per unit of dof j, for
    the dofs of body and its ancestors (nothing for the world, body -1)."""
    S = tree.S
    i = body
    while i >= 0:
        R = load33(oR, i)
        o = load3(op, i)
        r = (P[0] - o[0], P[1] - o[1], P[2] - o[2])
        k0 = tree.v_idx[i]
        for k in range(k0, k0 + tree.nv_j[i]):
            w = rot(R, (S[k, 0], S[k, 1], S[k, 2]))
            u = rot(R, (S[k, 3], S[k, 4], S[k, 5]))
            wr = cross(w, r)
            for m in range(3):
                A[m, k] += sign * (u[m] + wr[m])
        i = tree.parents[i]


@inline_kernel
def friction_slope(speed, mat):
    """(c, dc/d|v_t|) of the module docstring at slip speed ``speed`` >= 0 (c: :func:`.forces.friction_ratio`)."""
    vs, mu_s, mu_d = mat[K_VS], mat[K_MU_S], mat[K_MU_D]
    c = friction_ratio(speed, mat)
    if speed < vs:  # c = mu_s (2 - s) / v_s
        return c, -mu_s / (vs * vs)
    s = speed / vs
    mu = friction_coefficient(s, mu_s, mu_d)
    if s >= 3.0:  # c = mu_d / speed
        return c, -mu / (speed * speed)
    x = 0.5 * (s - 1.0)  # mu = mu_s - (mu_s - mu_d) step5(x): dmu/ds = -(mu_s - mu_d) 30 x^2 (1 - x)^2 / 2
    dmu = -(mu_s - mu_d) * 15.0 * x * x * (1.0 - x) * (1.0 - x)
    return c, dmu / (vs * speed) - mu / (speed * speed)


@inline_kernel
def force_derivatives(n, x, vrel, mat, G, Fx):
    """G (3, 3) = dF/dv_rel and Fx (3,) = dF/dx of one contact (module docstring)."""
    vn = dot(n, vrel)
    damp = max(0.0, 1.0 - mat[K_DISS] * vn)
    fn = mat[K_STIFF] * x * damp
    gn = -mat[K_STIFF] * x * mat[K_DISS] if damp > 0.0 else 0.0  # d f_n / d v_rel = gn n
    vt = (vrel[0] - vn * n[0], vrel[1] - vn * n[1], vrel[2] - vn * n[2])
    speed = np.sqrt(dot(vt, vt))
    c, dc = friction_slope(speed, mat)
    e = dc / speed if speed > 0.0 else 0.0
    for r in range(3):
        for m in range(3):
            Pt = (1.0 if r == m else 0.0) - n[r] * n[m]
            G[r, m] = n[r] * gn * n[m] - fn * (c * Pt + e * vt[r] * vt[m]) - c * vt[r] * gn * n[m]
        Fx[r] = mat[K_STIFF] * damp * (n[r] - c * vt[r])


@kernel
def contact_force_derivatives(tree, n, pair, point, normal, depth, pair_body, mat, oR, op, v, dq, dv):
    """dv = d tau_c/dv and dq = the stiffness part of d tau_c/dq (tangent space) of contacts 0..n-1 (the narrow
    phase's buffer, the bodies' world poses oR, op at q) at velocity v."""
    nv = v.shape[0]
    A = np.empty((3, nv))
    for r in range(nv):
        for m in range(nv):
            dq[r, m] = 0.0
            dv[r, m] = 0.0
    G, Fx, GA, nA = np.empty((3, 3)), np.empty(3), np.empty((3, nv)), np.empty(nv)
    for k in range(n):
        j = pair[k]
        P = load3(point, k)
        nrm = load3(normal, k)
        for m in range(3):
            for c in range(nv):
                A[m, c] = 0.0
        point_jacobian(tree, oR, op, pair_body[j, 0], P, 1.0, A)
        point_jacobian(tree, oR, op, pair_body[j, 1], P, -1.0, A)
        vrel = (0.0, 0.0, 0.0)
        for c in range(nv):
            vrel = (vrel[0] + A[0, c] * v[c], vrel[1] + A[1, c] * v[c], vrel[2] + A[2, c] * v[c])
        force_derivatives(nrm, depth[k], vrel, mat[j], G, Fx)
        for c in range(nv):
            for m in range(3):
                GA[m, c] = G[m, 0] * A[0, c] + G[m, 1] * A[1, c] + G[m, 2] * A[2, c]
            nA[c] = nrm[0] * A[0, c] + nrm[1] * A[1, c] + nrm[2] * A[2, c]
        for r in range(nv):
            a0, a1, a2 = A[0, r], A[1, r], A[2, r]
            if a0 == 0.0 and a1 == 0.0 and a2 == 0.0:  # a dof that does not move the point
                continue
            ax = a0 * Fx[0] + a1 * Fx[1] + a2 * Fx[2]
            for c in range(nv):
                dv[r, c] += a0 * GA[0, c] + a1 * GA[1, c] + a2 * GA[2, c]
                dq[r, c] -= ax * nA[c]


def force_derivatives_of(model, q, v, pair_body, point, normal, depth, mat):
    """(d tau_c/dq's stiffness part, d tau_c/dv) (nv x nv each) of a hand-made contact list at (q, v)
    (:func:`dynamics.contact.forces.contact_wrenches`'s arguments), in the C++ core."""
    from .. import _core
    dq, dv = np.empty((model.nv, model.nv)), np.empty((model.nv, model.nv))
    _core.contact_force_derivatives(model.core, np.ascontiguousarray(q, float), np.ascontiguousarray(v, float),
                                    np.ascontiguousarray(pair_body, np.int64), np.ascontiguousarray(mat, float),
                                    np.ascontiguousarray(point, float), np.ascontiguousarray(normal, float),
                                    np.ascontiguousarray(depth, float), dq, dv)
    return dq, dv
