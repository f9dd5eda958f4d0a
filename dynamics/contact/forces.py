"""Compliant point contact: each contact's force, and its share of every body's external wrench.

For contact k between geometries a and b (the narrow phase's record: point P, unit normal n from b towards a,
penetration x > 0, all in the world frame) with the pair's material (k, d, mu_s, mu_d, v_s):

    v_rel = v_a(P) - v_b(P)                      velocity of a's material point at P relative to b's
    xdot  = -n . v_rel                             penetration rate (> 0 while the geometries approach)
    f_n   = k x (1 + d xdot)_+                     Hunt & Crossley's dissipation on a linear spring (Drake's
                                                   point-contact law): continuous, and never pulls
    v_t   = v_rel - (n . v_rel) n,   s = |v_t| / v_s
    f_t   = -mu(s) f_n v_t / |v_t|                 regularised Coulomb friction
    mu(s) = mu_s s (2 - s)                          s < 1: stiction as a steep viscous law, slope 2 mu_s / v_s at
                                                   s = 0 (TAMSI's regularisation, Castro et al. 2019)
          = mu_s - (mu_s - mu_d) step5((s - 1) / 2)  1 <= s < 3: Drake's Stribeck drop to the dynamic coefficient
          = mu_d                                   s >= 3           (step5(x) = 10 x^3 - 15 x^4 + 6 x^5)
    F     = f_n n + f_t                            on a at P; -F on b at P (the world is no body)

mu(s) is C1: a body loaded below mu_s f_n slips at less than v_s (for a tangential load r mu_s f_n, at
v_s (1 - sqrt(1 - r)) ~ r v_s / 2), the stiction of a regularised law.  Drake's continuous plant uses step5 on
s < 1 too; its zero slope at s = 0 lets a standing robot creep ~10x faster under the same load.

Each force becomes body wrenches in :mod:`dynamics.rnea`'s ``f_ext`` convention (body frame, [force, torque
about the body origin]): f_i += [R_i^T F, R_i^T ((P - o_i) x F)], with (R_i, o_i) body i's world pose; and the
generalised force tau_c = sum_i J_i^T f_i by one backward pass (Featherstone 2008, sec. 5.3: f_p += X_i^T f_i,
tau_i = S_i^T f_i).  The contact power is P_c = sum_k F . v_rel_k = v . tau_c (the work quadrature of the
simulation).  Its integral is the energy the contacts gave the robot: minus the energy they dissipated (damping
and friction) minus the elastic energy 1/2 k x^2 they hold.
"""

import numpy as np

#: columns of a pair's material row (:attr:`dynamics.contact.resolve.Resolved.mat`; core/contact/forces.hpp)
K_STIFF, K_DISS, K_MU_S, K_MU_D, K_VS = range(5)
NMAT = 5
#: columns of a contact's detail row: normal force (N), friction force (3, world), slip velocity v_t (3, world,
#: a relative to b), elastic energy 1/2 k x^2 (J)
D_FN, D_FT, D_SLIP, D_ELASTIC = 0, 1, 4, 7
NDETAIL = 8


def contact_wrenches(model, q, v, pair_body, point, normal, depth, mat):
    """The law on a hand-made contact list at (q, v), in the C++ core (``core/contact/forces.hpp``): contact k
    between the bodies ``pair_body[k]`` (-1: the world) at the world point ``point[k]`` with the unit normal
    ``normal[k]`` (from b towards a), penetration ``depth[k]`` and material row ``mat[k]``.  Returns (f_ext (nb, 6),
    tau_c (nv,), contact power, detail (K, NDETAIL))."""
    from .. import _core
    nb, K = model.tree.parents.shape[0], len(depth)
    f_ext, tau, detail = np.zeros((nb, 6)), np.zeros(model.nv), np.zeros((K, NDETAIL))
    power = _core.contact_wrenches(model.core, np.ascontiguousarray(q, float), np.ascontiguousarray(v, float),
                                   np.ascontiguousarray(pair_body, np.int64), np.ascontiguousarray(mat, float),
                                   np.ascontiguousarray(point, float), np.ascontiguousarray(normal, float),
                                   np.ascontiguousarray(depth, float), f_ext, tau, detail)
    return f_ext, tau, power, detail
