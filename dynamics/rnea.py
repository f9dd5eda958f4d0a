"""Inverse dynamics by the Recursive Newton-Euler Algorithm (Featherstone 2008, sec. 5.3, Table 5.1).

    tau = M(q) a + C(q, v) v + g(q) - sum_i J_i^T f_ext_i

Body-frame formulation.  Gravity enters as a fictitious upward acceleration of the world, a_0 = (0, -g).
Forward pass, for each body i with parent p and joint velocity v_J = S_i qd_i:

    v_i = X_i v_p + S_i qd_i
    a_i = X_i a_p + S_i qdd_i + v_i x (S_i qd_i)
    f_i = I_i a_i + v_i x* I_i v_i - f_ext_i

Backward pass:  tau_i = S_i^T f_i ,  f_p += X_i^T f_i .
"""

from typing import NamedTuple

import numpy as np

from . import checks
from ._numba import (borrow, VECTOR, address, helper, inline_kernel, keep_alive, kernel, scratch, SingleCall, view,
                     )
from .checks import NOT_ARRAYS, DONE, GENERAL, _config_shape_ok, _finite, _nonzero, _roots_finite
from .data import Data, _data_at, _forward_body, _take
from .model import _unpack
from .parallel import run_chunks
from .joints import _joint_motion, _joint_transform, _project_force
from .spatial import (add, cross, cross_force, force_to_parent, inertia_times, load3, load33,
                      motion_to_child, rot, rotT, scale, store3, store33)


class Work(NamedTuple):
    """RNEA's scratch for one state: the forward pass's :class:`~dynamics.data.Data`, then per body (nb, 3)
    its spatial acceleration (aw, av) and the force it transmits to its parent (n, f), body frame."""

    d: Data
    aw: object
    av: object
    n: object
    f: object


@inline_kernel
def _work_at(base, o, nb):
    """A :class:`Work` carved from the buffer at ``base`` from offset o (at base 0: only its size), and the
    offset after it."""
    d, o = _data_at(base, o, nb)
    aw, o = _take(base, o, (nb, 3))
    av, o = _take(base, o, (nb, 3))
    n, o = _take(base, o, (nb, 3))
    f, o = _take(base, o, (nb, 3))
    return Work(d, aw, av, n, f), o


@helper
def _workspace(nb):
    """A :class:`Work` of owned arrays, which the caller may keep (a torque source's scratch)."""
    d = Data(np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)),
             np.empty((nb, 3)))
    return Work(d, np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)))


class GravityWork(NamedTuple):
    """g(q)'s scratch: poses (R, p), each body's gravity g_i, its subtree's first moment H_i (nb, 3) and mass
    M_i (nb,)."""

    R: object
    p: object
    g: object
    H: object
    M: object


@inline_kernel
def _gravity_work_at(base, o, nb):
    R, o = _take(base, o, (nb, 3, 3))
    p, o = _take(base, o, (nb, 3))
    g, o = _take(base, o, (nb, 3))
    H, o = _take(base, o, (nb, 3))
    M, o = _take(base, o, nb)
    return GravityWork(R, p, g, H, M), o


@inline_kernel
def _rnea_terms(tree, q, v, a, gravity, f_ext, ws, tau, with_v, with_a):
    """RNEA for one state into ``tau``; ``f_ext`` is (nb, 6) [force, torque] per body or (0, 6).

    ``with_v=False`` (v is zero) skips the velocity pass and every velocity-product term; ``with_a=False``
    (a is zero) skips the joint accelerations: the caller promises those inputs are zero.
    """
    parents, mass, hs, Ios = tree.parents, tree.mass, tree.h, tree.Io
    d = ws.d
    zero = (0.0, 0.0, 0.0)
    a0 = (-gravity[0], -gravity[1], -gravity[2])  # the world accelerates up: a_0 = (0, -g)
    nb = parents.shape[0]
    for i in range(nb):  # X_i, v_i, c_i;  a_i = X_i a_p + S_i qdd_i + c_i,  f_i = I a + v x* I v - f_ext
        R, p, w, vl, cw, cv = _forward_body(tree, i, q, v, d, with_v)
        par = parents[i]
        if par < 0:
            aw, al = motion_to_child(R, p, zero, a0)
        else:
            aw, al = motion_to_child(R, p, load3(ws.aw, par), load3(ws.av, par))
        if with_a:
            sw, sv = _joint_motion(tree, i, a)
            aw, al = add(aw, sw), add(al, sv)
        m, h, Io = mass[i], load3(hs, i), load33(Ios, i)
        if with_v:
            aw, al = add(aw, cw), add(al, cv)
        n, f = inertia_times(m, h, Io, aw, al)
        if with_v:
            hn, hf = inertia_times(m, h, Io, w, vl)
            bn, bf = cross_force(w, vl, hn, hf)
            n, f = add(n, bn), add(f, bf)
        if f_ext.shape[0] > 0:
            n = (n[0] - f_ext[i, 3], n[1] - f_ext[i, 4], n[2] - f_ext[i, 5])
            f = (f[0] - f_ext[i, 0], f[1] - f_ext[i, 1], f[2] - f_ext[i, 2])
        store3(ws.aw, i, aw)
        store3(ws.av, i, al)
        store3(ws.n, i, n)
        store3(ws.f, i, f)
    for i in range(nb - 1, -1, -1):  # tau_i = S_i^T f_i,  f_p += X_i^T f_i
        n, f = load3(ws.n, i), load3(ws.f, i)
        _project_force(tree, i, n, f, tau)
        par = parents[i]
        if par >= 0:
            pn, pf = force_to_parent(load33(d.R, i), load3(d.p, i), n, f)
            store3(ws.n, par, add(load3(ws.n, par), pn))
            store3(ws.f, par, add(load3(ws.f, par), pf))


@inline_kernel
def _gravity_into(tree, q, gravity, ws, tau):
    """g(q): RNEA at v = a = 0, where each body's force reduces to the weight of its subtree.

    With a_0 = (0, -g) every a_i = (0, -g_i), g_i = R_i^T g_p, so f_i summed over the subtree of i is
    (-H_i x g_i, -M_i g_i) with M_i, H_i the subtree's mass and first moment in frame i:
    tau_i = S_i^T (-H_i x g_i, -M_i g_i).  No inertia tensor and no velocity enters.
    """
    parents, mass, hs = tree.parents, tree.mass, tree.h
    Rs, ps, gs, Hs, Ms = ws
    nb = parents.shape[0]
    for i in range(nb):
        R, p = _joint_transform(tree, i, q)
        par = parents[i]
        g = rotT(R, (gravity[0], gravity[1], gravity[2]) if par < 0 else load3(gs, par))
        store33(Rs, i, R)
        store3(ps, i, p)
        store3(gs, i, g)
        store3(Hs, i, load3(hs, i))
        Ms[i] = mass[i]
    for i in range(nb - 1, -1, -1):
        H, M, g = load3(Hs, i), Ms[i], load3(gs, i)
        _project_force(tree, i, cross(g, H), scale(-M, g), tau)  # -H x g = g x H
        par = parents[i]
        if par >= 0:
            store3(Hs, par, add(load3(Hs, par), add(rot(load33(Rs, i), H), scale(M, load3(ps, i)))))
            Ms[par] += M


@kernel
def _gravity_batch(tree, Q, gravity, out):
    # the arguments as views with no owner: no reference counts in the loops (dynamics._numba.borrow)
    tree, Q, gravity, out = borrow(tree), borrow(Q), borrow(gravity), borrow(out)
    nb = tree.parents.shape[0]
    buf = np.empty(_gravity_work_at(0, 0, nb)[1])
    ws = _gravity_work_at(address(buf), 0, nb)[0]
    for b in range(Q.shape[0]):
        _gravity_into(tree, Q[b], gravity, ws, out[b])
    keep_alive(buf)


@kernel
def _rnea_into(tree, q, v, a, gravity, f_ext, ws, tau):
    """RNEA for one state into ``tau`` with every term."""
    _rnea_terms(tree, q, v, a, gravity, f_ext, ws, tau, True, True)


@kernel
def _rnea_batch(tree, Q, V, A, F, gravity, with_v, with_a, out):
    """Rows of ``out`` = RNEA of the rows of Q, V, A (V or A may have one row when unused); F is
    (1 or B, nb or 0, 6)."""
    tree, Q, V, A, F, out = borrow(tree), borrow(Q), borrow(V), borrow(A), borrow(F), borrow(out)
    nb = tree.parents.shape[0]
    buf = np.empty(_work_at(0, 0, nb)[1])
    ws = _work_at(address(buf), 0, nb)[0]
    lf, lv, la = F.shape[0] - 1, V.shape[0] - 1, A.shape[0] - 1
    for b in range(Q.shape[0]):
        _rnea_terms(tree, Q[b], V[min(b, lv)], A[min(b, la)], gravity, F[min(b, lf)], ws, out[b], with_v, with_a)
    keep_alive(buf)


# -- one state from Python: inputs checked inside the call (status codes of dynamics.checks) ----------------
def _rnea_one(packed, q, v, a, tau):
    tree, gravity, nq = _unpack(packed)
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    if not (_config_shape_ok(tree, nq, q) and v.shape[0] == nv and a.shape[0] == nv and tau.shape[0] == nv):
        return GENERAL
    buf = scratch(_work_at(0, 0, nb)[1])
    _rnea_terms(tree, q, v, a, gravity, view(buf, 0, (0, 6)), _work_at(address(buf), 0, nb)[0], tau, _nonzero(v),
               _nonzero(a))
    keep_alive(buf)
    return DONE if _finite(tau) else GENERAL


def _bias_one(packed, q, v, tau):
    tree, gravity, nq = _unpack(packed)
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    if not (_config_shape_ok(tree, nq, q) and v.shape[0] == nv and tau.shape[0] == nv):
        return GENERAL
    buf = scratch(_work_at(0, 0, nb)[1])
    _rnea_terms(tree, q, v, v, gravity, view(buf, 0, (0, 6)), _work_at(address(buf), 0, nb)[0], tau, _nonzero(v),
               False)
    keep_alive(buf)
    return DONE if _finite(tau) else GENERAL


def _gravity_one(packed, q, tau):
    tree, gravity, nq = _unpack(packed)
    nb = tree.parents.shape[0]
    if not (_config_shape_ok(tree, nq, q) and _roots_finite(tree, nq, q) and tau.shape[0] == tree.S.shape[0]):
        return GENERAL
    buf = scratch(_gravity_work_at(0, 0, nb)[1])
    _gravity_into(tree, q, gravity, _gravity_work_at(address(buf), 0, nb)[0], tau)
    keep_alive(buf)
    return DONE if _finite(tau) else GENERAL





# -- public entry points ---------------------------------------------------------------------------
_rnea_batch = _rnea_batch
_gravity_batch = _gravity_batch
_rnea_single = SingleCall(_rnea_one, VECTOR, VECTOR, VECTOR, VECTOR)
_bias_single = SingleCall(_bias_one, VECTOR, VECTOR, VECTOR)
_gravity_single = SingleCall(_gravity_one, VECTOR, VECTOR)


def _run(model, q, v, a, gravity, f_ext):
    checks.check_model(model)
    Q, (V, A), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("a", a, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    with_v, with_a = bool(V.any()), bool(A.any())  # zero terms are skipped, not computed
    out = np.empty((B, model.nv))
    run_chunks(_rnea_batch, model.tree, (Q, V, A, F), (g, with_v, with_a), out)
    return out if batched else out[0]


def skipped_terms(v=None, a=None, gravity=(0.0, 0.0, -9.81)):
    """Names of the terms a call with these inputs does not compute (for scene reports)."""
    out = []
    if v is None or not np.any(v):
        out.append("velocity products")
    if a is None or not np.any(a):
        out.append("joint accelerations")
    if gravity is not None and not np.any(gravity):
        out.append("gravity")
    return out


def inverse_dynamics(model, q, v, a, *, gravity=None, f_ext=None):
    """Joint torques tau = M(q) a + C(q, v) v + g(q) - J^T f_ext (RNEA).

    q: (nq,) or (B, nq); v, a: (nv,) or (B, nv); gravity: (3,) in the world frame (default model.gravity);
    f_ext: (nbodies, 6) or (B, nbodies, 6), one [force, torque] per body in its body frame, torque about the
    body frame origin.  Returns tau of shape (nv,) or (B, nv).
    """
    try:  # one state: one compiled call, which checks q, v and a itself (anything else takes the general path)
        if gravity is None and f_ext is None:
            tau = np.empty(model.nv)
            if _rnea_single.call(model.packed, q, v, a, tau) == DONE:
                return tau
    except NOT_ARRAYS:  # not a model, or arrays of other types: the general path says what is wrong or converts
        pass
    return _run(model, q, v, a, gravity, f_ext)


def gravity_torques(model, q, *, gravity=None):
    """g(q): the torques that hold the robot still against gravity, (nv,) or (B, nv)."""
    try:  # the fast path, as in inverse_dynamics
        if gravity is None:
            tau = np.empty(model.nv)
            if _gravity_single.call(model.packed, q, tau) == DONE:
                return tau
    except NOT_ARRAYS:
        pass
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    out = np.empty((Q.shape[0], model.nv))
    run_chunks(_gravity_batch, model.tree, (Q,), (checks.gravity_vector(model, gravity),), out)
    return out if batched else out[0]


def bias_forces(model, q, v, *, gravity=None):
    """C(q, v) v + g(q): inverse dynamics at zero acceleration, (nv,) or (B, nv)."""
    try:  # the fast path, as in inverse_dynamics
        if gravity is None:
            tau = np.empty(model.nv)
            if _bias_single.call(model.packed, q, v, tau) == DONE:
                return tau
    except NOT_ARRAYS:
        pass
    checks.check_model(model)
    return _run(model, q, v, np.zeros(model.nv), gravity, None)
