"""The robot's centre of mass, its velocity and its Jacobian (Pinocchio's centerOfMass and
jacobianCenterOfMass), world frame.

With body i at world pose (oR_i, op_i), mass m_i and first moment h_i = m_i c_i (body frame), the total mass
m = sum m_i and

    com  = sum_i (oR_i h_i + m_i op_i) / m
    vcom = sum_i oR_i (m_i v_i + w_i x h_i) / m            (body velocities (w_i, v_i) in body frames)
    Jcom[:, k] = (m_s v_k + w_k x H_s) / m                  (k a velocity coordinate of joint i)

where (w_k, v_k) is column k of the spatial world Jacobian (the motion axis at the world origin,
:mod:`dynamics.jacobians`) and m_s, H_s = sum (oR_j h_j + m_j op_j) are the mass and world first moment of
the subtree of i, accumulated from the leaves in (O(n)).  Links welded to the world are not bodies and do not
count.
"""

import numpy as np

from . import checks
from ._numba import (MATRIX, SingleCall, VECTOR, address, borrow, inline_kernel, keep_alive, kernel, scratch,
                     view)
from .checks import DONE, GENERAL, NOT_ARRAYS, _config_ok
from .joints import _joint_motion
from .kinematics import _world_pose
from .data import _take
from .model import _unpack
from .parallel import run_chunks
from .spatial import add, cross, load3, load33, motion_to_child, rot, scale, store3

COM, VELOCITY, JACOBIAN = 0, 1, 2


@kernel
def _com_batch(model_tree, Q, V, what, out):
    """Per state into out[b] (3, 1 or nv): com, vcom (what = VELOCITY) or Jcom (what = JACOBIAN)."""
    # borrowed: _com_into takes the arrays out of the tuple, and out[b] is a view, per state: no reference counts
    tree, rows = borrow(model_tree), borrow(out)
    nb = tree.parents.shape[0]
    oR, op, H, ms = np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty(nb)
    ws, vs = np.empty((nb, 3)), np.empty((nb, 3))
    inv_m = _inverse_mass(tree)
    lv = V.shape[0] - 1
    for b in range(Q.shape[0]):
        _com_into(tree, Q[b], V[min(b, lv)], what, inv_m, oR, op, H, ms, ws, vs, rows[b])
    keep_alive(model_tree)
    keep_alive(out)


@inline_kernel
def _inverse_mass(tree):
    m = 0.0
    for i in range(tree.mass.shape[0]):
        m += tree.mass[i]
    return 1.0 / m if m > 0.0 else 0.0


@inline_kernel
def _com_into(tree, q, v, what, inv_m, oR, op, H, ms, ws, vs, out):
    """One state into out (3, 1 or nv); oR, op, H, ms, ws, vs are scratch."""
    parents, mass, hs, S, v_idx, nv_j = tree.parents, tree.mass, tree.h, tree.S, tree.v_idx, tree.nv_j
    nb = parents.shape[0]
    zero = (0.0, 0.0, 0.0)
    c = zero
    for i in range(nb):
        Rl, pl, R, p = _world_pose(tree, i, q, oR, op)
        par = parents[i]
        w, vl = zero, zero
        if par >= 0 and what == VELOCITY:
            w, vl = motion_to_child(Rl, pl, load3(ws, par), load3(vs, par))
        h = load3(hs, i)
        Hi = add(rot(R, h), scale(mass[i], p))  # the body's world first moment
        if what == COM:
            c = add(c, Hi)
        elif what == VELOCITY:  # momentum oR (m v + w x h)
            wJ, vJ = _joint_motion(tree, i, v)
            w, vl = add(w, wJ), add(vl, vJ)
            store3(ws, i, w)
            store3(vs, i, vl)
            c = add(c, rot(R, add(scale(mass[i], vl), cross(w, h))))
        store3(H, i, Hi)
        ms[i] = mass[i]
    if what != JACOBIAN:
        out[0, 0], out[1, 0], out[2, 0] = scale(inv_m, c)
        return
    for i in range(nb - 1, -1, -1):  # subtree masses and world first moments
        par = parents[i]
        if par >= 0:
            ms[par] += ms[i]
            store3(H, par, add(load3(H, par), load3(H, i)))
    for i in range(nb):
        R, p, Hs = load33(oR, i), load3(op, i), load3(H, i)
        for k in range(v_idx[i], v_idx[i] + nv_j[i]):
            w = rot(R, (S[k, 0], S[k, 1], S[k, 2]))
            vk = add(rot(R, (S[k, 3], S[k, 4], S[k, 5])), cross(p, w))
            out[0, k], out[1, k], out[2, k] = scale(inv_m, add(scale(ms[i], vk), cross(w, Hs)))


@inline_kernel
def _com_single_into(packed, q, what, out):
    """One state from Python into out (3, 1 or nv), q checked here (status codes of dynamics.checks)."""
    tree, gravity, nq = _unpack(packed)
    nb = tree.parents.shape[0]
    if not _config_ok(tree, nq, q):
        return GENERAL
    buf = scratch(22 * nb)
    oR, o = _take(address(buf), 0, (nb, 3, 3))
    op, o = _take(address(buf), o, (nb, 3))
    H, o = _take(address(buf), o, (nb, 3))
    ms, o = _take(address(buf), o, nb)
    ws, o = _take(address(buf), o, (nb, 3))
    vs, o = _take(address(buf), o, (nb, 3))
    _com_into(tree, q, q, what, _inverse_mass(tree), oR, op, H, ms, ws, vs, out)
    keep_alive(buf)
    return DONE


def _com_one(packed, q, com):
    return _com_single_into(packed, q, COM, view(com, 0, (3, 1)))


def _com_jacobian_one(packed, q, J):
    return _com_single_into(packed, q, JACOBIAN, J)


# -- public entry points ---------------------------------------------------------------------------
_com_batch = _com_batch
_com_single = SingleCall(_com_one, VECTOR, VECTOR)
_com_jacobian_single = SingleCall(_com_jacobian_one, VECTOR, MATRIX)


def _run(model, q, v, what):
    checks.check_model(model)
    if v is None:
        Q, batched = checks.configurations(model, q)
        V, B = Q[:1, :0], Q.shape[0]
    else:
        Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = np.empty((B, 3, model.nv if what == JACOBIAN else 1))
    run_chunks(_com_batch, model.tree, (Q, V), (what,), out)
    if what != JACOBIAN:
        out = out[:, :, 0]
    return out if batched else out[0]


def center_of_mass(model, q):
    """The robot's centre of mass in the world, (3,) or (B, 3) (``model.total_mass`` is its mass)."""
    try:  # one state: one compiled call, which checks q (anything else takes the general path)
        out = np.empty(3)
        if _com_single.call(model.packed, q, out) == DONE:
            return out
    except NOT_ARRAYS:
        pass
    return _run(model, q, None, COM)


def center_of_mass_velocity(model, q, v):
    """The velocity of the centre of mass in the world, (3,) or (B, 3)."""
    return _run(model, q, v, VELOCITY)


def com_jacobian(model, q):
    """Jcom (3, nv) or (B, 3, nv), world frame: center_of_mass_velocity = Jcom v."""
    try:  # the fast path, as in center_of_mass
        out = np.empty((3, model.nv))
        if _com_jacobian_single.call(model.packed, q, out) == DONE:
            return out
    except NOT_ARRAYS:
        pass
    return _run(model, q, None, JACOBIAN)
