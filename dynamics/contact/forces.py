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

from typing import NamedTuple

import numpy as np
from .._numba import inline_kernel, kernel
from ..data import Data, _forward_body
from ..spatial import add, cross, dot, load3, load33, matmul, rot, rotT, scale, store3, store33

#: columns of a pair's material row (:attr:`ContactModel.mat`)
K_STIFF, K_DISS, K_MU_S, K_MU_D, K_VS = range(5)
NMAT = 5
#: columns of a contact's detail row (:attr:`ContactModel.detail`): normal force (N), friction force (3, world),
#: slip velocity v_t (3, world, a relative to b), elastic energy 1/2 k x^2 (J)
D_FN, D_FT, D_SLIP, D_ELASTIC = 0, 1, 4, 7
NDETAIL = 8


class ContactWork(NamedTuple):
    """Scratch of the force law for one state: the forward pass (:class:`dynamics.data.Data`), every body's world
    pose (oR (nb, 3, 3), op (nb, 3)) and its accumulated wrench fb (nb, 6): body frame, [force, torque]."""

    d: Data
    oR: np.ndarray
    op: np.ndarray
    fb: np.ndarray


def contact_work(nb):
    """A :class:`ContactWork` of owned arrays for nb bodies."""
    d = Data(np.zeros((nb, 3, 3)), np.zeros((nb, 3)), np.zeros((nb, 3)), np.zeros((nb, 3)), np.zeros((nb, 3)),
             np.zeros((nb, 3)))
    return ContactWork(d, np.zeros((nb, 3, 3)), np.zeros((nb, 3)), np.zeros((nb, 6)))


@inline_kernel
def world_kinematics(tree, q, v, ws, with_v):
    """ws.d = the forward pass at (q, v) (with ``with_v`` the body-frame velocities too); ws.oR, ws.op = every
    body's world pose.  The narrow phase needs the poses only; the force law the velocities, when something
    touches (:func:`dynamics.contact.resolve.evaluate`): a robot touching nothing pays one pose pass.

    The arrays are taken out of ``ws`` once, before the loop: taking a field of a tuple of arrays inside it
    costs compiled code a reference count per array and body (measured: 4.8 us against 0.2 us on Go1)."""
    d, oR, op = ws.d, ws.oR, ws.op
    for i in range(tree.parents.shape[0]):
        R, p, w, vl, cw, cv = _forward_body(tree, i, q, v, d, with_v)
        world_pose(tree, i, R, p, oR, op)


@inline_kernel
def world_pose(tree, i, R, p, oR, op):
    """oR[i], op[i] = body i's world pose from its pose (R, p) in its parent's frame (the parent's is done)."""
    par = tree.parents[i]
    if par < 0:
        store33(oR, i, R)
        store3(op, i, p)
    else:
        oRp = load33(oR, par)
        store33(oR, i, matmul(oRp, R))
        store3(op, i, add(load3(op, par), rot(oRp, p)))


@inline_kernel
def world_poses(tree, d, oR, op):
    """Every body's world pose from a forward pass already done (d.R, d.p: poses in the parents' frames)."""
    dR, dp = d.R, d.p
    for i in range(tree.parents.shape[0]):
        world_pose(tree, i, load33(dR, i), load3(dp, i), oR, op)


@inline_kernel
def point_velocity(ws, body, P):
    """World velocity of body's material point at the world point P (zero for the world, body -1)."""
    if body < 0:
        return (0.0, 0.0, 0.0)
    R = load33(ws.oR, body)
    o = load3(ws.op, body)
    r = rotT(R, (P[0] - o[0], P[1] - o[1], P[2] - o[2]))
    return rot(R, add(load3(ws.d.vl, body), cross(load3(ws.d.w, body), r)))


@inline_kernel
def friction_coefficient(s, mu_s, mu_d):
    """mu(s) of the module docstring, s = slip speed / stiction velocity >= 0."""
    if s >= 3.0:
        return mu_d
    if s >= 1.0:
        x = 0.5 * (s - 1.0)
        return mu_s - (mu_s - mu_d) * x * x * x * (10.0 + x * (6.0 * x - 15.0))
    return mu_s * s * (2.0 - s)


@inline_kernel
def friction_ratio(speed, mat):
    """c = mu(s) / |v_t| at slip speed ``speed`` >= 0 (f_t = -c f_n v_t; s = speed / v_s): below v_s it is
    mu_s (2 - s) / v_s, with no division by a vanishing speed."""
    vs = mat[K_VS]
    if speed < vs:
        return mat[K_MU_S] * (2.0 - speed / vs) / vs
    return friction_coefficient(speed / vs, mat[K_MU_S], mat[K_MU_D]) / speed


@inline_kernel
def contact_force(n, x, vrel, mat):
    """(f_n, f_t, v_t) of one contact (module docstring): the normal force (N), the friction force and the slip
    velocity (world 3-tuples).  n: unit normal from b to a; x > 0: penetration; vrel: v_a - v_b at the point;
    mat: the pair's material row."""
    vn = dot(n, vrel)
    fn = mat[K_STIFF] * x * max(0.0, 1.0 - mat[K_DISS] * vn)
    vt = (vrel[0] - vn * n[0], vrel[1] - vn * n[1], vrel[2] - vn * n[2])
    speed = np.sqrt(dot(vt, vt))
    c = friction_ratio(speed, mat)
    return fn, scale(-c * fn, vt), vt


@inline_kernel
def add_wrench(ws, body, P, F):
    """Body ``body``'s wrench += the world force F at the world point P, in its frame about its origin."""
    if body < 0:
        return
    R = load33(ws.oR, body)
    o = load3(ws.op, body)
    f = rotT(R, F)
    t = rotT(R, cross((P[0] - o[0], P[1] - o[1], P[2] - o[2]), F))
    for r in range(3):
        ws.fb[body, r] += f[r]
        ws.fb[body, 3 + r] += t[r]


@inline_kernel
def apply_contacts(n, pair, point, normal, depth, pair_body, mat, ws, detail):
    """The forces of contacts 0..n-1 (arrays of the narrow phase's buffer; pair_body (npairs, 2): the bodies of
    each pair's geometries a, b) added to ws.fb (zeroed first); detail[k] = contact k's row (NDETAIL columns).
    Returns the contact power sum_k F_k . v_rel_k (W)."""
    for i in range(ws.fb.shape[0]):
        for r in range(6):
            ws.fb[i, r] = 0.0
    power = 0.0
    for k in range(n):
        j = pair[k]
        ba, bb = pair_body[j, 0], pair_body[j, 1]
        P = load3(point, k)
        nrm = load3(normal, k)
        va, vb = point_velocity(ws, ba, P), point_velocity(ws, bb, P)
        vrel = (va[0] - vb[0], va[1] - vb[1], va[2] - vb[2])
        fn, ft, vt = contact_force(nrm, depth[k], vrel, mat[j])
        F = add(scale(fn, nrm), ft)
        power += dot(F, vrel)
        add_wrench(ws, ba, P, F)
        add_wrench(ws, bb, P, (-F[0], -F[1], -F[2]))
        detail[k, D_FN] = fn
        for r in range(3):
            detail[k, D_FT + r] = ft[r]
            detail[k, D_SLIP + r] = vt[r]
        detail[k, D_ELASTIC] = 0.5 * mat[j, K_STIFF] * depth[k] * depth[k]
    return power


@inline_kernel
def generalized_forces(tree, ws, tau):
    """tau += sum_i J_i^T fb_i (one backward pass; ws.fb is consumed: it ends as the subtrees' wrenches)."""
    S, fb = tree.S, ws.fb
    for i in range(tree.parents.shape[0] - 1, -1, -1):
        f = (fb[i, 0], fb[i, 1], fb[i, 2])
        t = (fb[i, 3], fb[i, 4], fb[i, 5])
        k0 = tree.v_idx[i]
        for k in range(k0, k0 + tree.nv_j[i]):
            tau[k] += S[k, 0] * t[0] + S[k, 1] * t[1] + S[k, 2] * t[2] + S[k, 3] * f[0] + S[k, 4] * f[1] + S[k, 5] * f[2]
        par = tree.parents[i]
        if par >= 0:
            R = load33(ws.d.R, i)
            p = load3(ws.d.p, i)
            fP = rot(R, f)
            tP = add(rot(R, t), cross(p, fP))
            for r in range(3):
                fb[par, r] += fP[r]
                fb[par, 3 + r] += tP[r]


@kernel
def _contacts_kernel(tree, q, v, n, pair, point, normal, depth, pair_body, mat, ws, detail, f_ext, tau):
    """For given contacts at (q, v): f_ext (nb, 6) = the body wrenches, tau += their generalised force; returns
    the contact power.  (Tests and :func:`dynamics.contact_forces` on a hand-made contact list.)"""
    world_kinematics(tree, q, v, ws, True)
    power = apply_contacts(n, pair, point, normal, depth, pair_body, mat, ws, detail)
    for i in range(f_ext.shape[0]):
        for r in range(6):
            f_ext[i, r] = ws.fb[i, r]
    generalized_forces(tree, ws, tau)
    return power


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
