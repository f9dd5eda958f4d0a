"""Derivatives of the generalised contact force tau_c = sum_k A_k^T F_k (:mod:`.forces`) for the simulation's
Jacobian (``core/simulation/robot_jacobian.cpp``), from the contacts an evaluation found; computed by the core
(``core/contact/force_derivatives.cpp``).

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
it (``RobotProblem::contact_terms``).

G and F_x from the law of :mod:`.forces` (s = |v_t| / v_s, c(|v_t|) = mu(s) / |v_t|, so that f_t = -c f_n v_t;
P_t = 1 - n n^T):

    d f_n / d v_rel = -k x d n      while 1 - d v_n > 0 (else 0),     d f_n / dx = k (1 - d v_n)_+
    d f_t / d v_rel = -f_n (c P_t + c'(|v_t|) v_t v_t^T / |v_t|) - c v_t (d f_n / d v_rel)^T
    G = n (d f_n / d v_rel)^T + d f_t / d v_rel,      F_x = (d f_n / dx) (n - c v_t)
"""

import numpy as np


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
