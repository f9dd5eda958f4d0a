"""Forward kinematics of frames: placements, velocities and accelerations (Featherstone 2008, sec. 4.1-4.2;
Pinocchio's forwardKinematics / getFrameVelocity / getFrameAcceleration).

Placements.  Body i's world pose composes its parent's with the joint transform (R_i, p_i) of
:func:`dynamics.joints._joint_transform`, and a frame fixed to body b at (R_bf, p_bf) in it is

    oR_i = oR_p R_i,   op_i = oR_p p_i + op_p,       oR_f = oR_b R_bf,   op_f = oR_b p_bf + op_b.

Velocities and accelerations, body frame, along the frame's support (body b and its ancestors):

    v_i = X_i v_p + S_i qd_i,    a_i = X_i a_p + S_i qdd_i + v_i x (S_i qd_i),     v_0 = a_0 = 0

(no gravity: a_i is the true spatial acceleration).  The frame's own motion is X_fb (v_b, a_b), then
expressed in one of three references (Pinocchio's ReferenceFrame, same meaning):

* ``"local"``: the frame's axes, linear part of the frame origin's point;
* ``"local_world_aligned"``: the frame origin's point, world axes (the local vectors rotated by oR_f);
* ``"world"``: the spatial vector at the world origin (oX_f applied: w0 = oR_f w, v0 = oR_f v + op_f x w0).

Every 6-vector is returned as [linear; angular].  The *classical* acceleration adds w x v to the linear
part of the spatial one (in the same reference): at the local references it is the second time derivative of
the frame origin's position (in local axes for "local"); at "world" that of the body point passing the world
origin.  :func:`frame_bias_acceleration` is the classical acceleration at a = 0, the Jdot v of
xdd = J a + Jdot v.
"""

import numpy as np
from numba import types

from . import checks
from ._numba import (borrow, SingleCall, VECTOR, address, inline_kernel, keep_alive, kernel, scratch)
from .checks import NOT_ARRAYS, DONE, GENERAL, _config_shape_ok, _finite
from .joints import _joint_motion, _joint_transform
from .data import _take
from .model import FRAME_BODY, FRAME_SHIFTED, FRAME_WORLD, _unpack, _unpack_frames
from .parallel import run_chunks
from .spatial import add, cross, cross_motion, load3, load33, matmul, motion_to_child, rot, store3, store33

WORLD, LOCAL, LOCAL_WORLD_ALIGNED = (checks.REFERENCES[k] for k in ("world", "local", "local_world_aligned"))


@inline_kernel
def _support(parents, body, path):
    """path[:n] = body's ancestors and body itself, root first; returns n (0 for the world, body -1)."""
    n = 0
    j = body
    while j >= 0:
        path[n] = j
        n += 1
        j = parents[j]
    for t in range(n // 2):
        path[t], path[n - 1 - t] = path[n - 1 - t], path[t]
    return n


@inline_kernel
def _world_pose(tree, i, q, oR, op):
    """oR[i], op[i] = body i's world pose from its parent's (already there); returns its joint transform
    (R, p) in the parent and its world pose (oR_i, op_i)."""
    R, p = _joint_transform(tree, i, q)
    par = tree.parents[i]
    oRi, opi = R, p
    if par >= 0:
        Rp = load33(oR, par)
        oRi, opi = matmul(Rp, R), add(rot(Rp, p), load3(op, par))
    store33(oR, i, oRi)
    store3(op, i, opi)
    return R, p, oRi, opi


@inline_kernel
def _world_poses(tree, q, path, n, oR, op):
    """oR[i], op[i] = world pose of each body i in path[:n] (parents before children)."""
    for t in range(n):
        _world_pose(tree, path[t], q, oR, op)


@inline_kernel
def _frame_pose(frames, f, oR, op):
    """World pose (R, p) of frame f from its body's world pose (only the products its kind needs)."""
    b, kind = frames.body[f], frames.kind[f]
    if kind == FRAME_BODY:  # most frames (a link's, its joint's)
        return load33(oR, b), load3(op, b)
    R, p = load33(frames.R, f), load3(frames.p, f)
    if kind == FRAME_WORLD:
        return R, p
    Rb, pb = load33(oR, b), load3(op, b)
    if kind == FRAME_SHIFTED:
        return Rb, add(rot(Rb, p), pb)
    return matmul(Rb, R), add(rot(Rb, p), pb)


@inline_kernel
def _in_reference(ref, R, p, w, v):
    """A motion (w, v) given in the local frame at pose (R, p), in reference ``ref``: (linear, angular)."""
    if ref == LOCAL:
        return v, w
    w0, v0 = rot(R, w), rot(R, v)
    if ref == LOCAL_WORLD_ALIGNED:
        return v0, w0
    return add(v0, cross(p, w0)), w0


def _workspace(nb):
    """Per-chunk scratch: the support path and the bodies' world poses."""
    return np.empty(nb, np.int64), np.empty((nb, 3, 3)), np.empty((nb, 3))


@inline_kernel
def _store_pose(R, p, T):
    """T = [[R, p], [0, 1]] (4x4)."""
    for r in range(3):
        T[r, 0], T[r, 1], T[r, 2], T[r, 3] = R[3 * r], R[3 * r + 1], R[3 * r + 2], p[r]
        T[3, r] = 0.0
    T[3, 3] = 1.0


@kernel
def _placements_batch(tree, Q, frames, out):
    """out[b, f] = 4x4 world placement of every frame f at Q[b]."""
    # the arguments as views with no owner: no reference counts in the loops (dynamics._numba.borrow)
    tree, Q, frames = borrow(tree), borrow(Q), borrow(frames)
    out = borrow(out)
    nb = tree.parents.shape[0]
    oR, op = np.empty((nb, 3, 3)), np.empty((nb, 3))
    for b in range(Q.shape[0]):
        _placements_into(tree, frames, Q[b], oR, op, out[b])


@inline_kernel
def _placements_into(tree, frames, q, oR, op, out):
    """out[f] = 4x4 world placement of every frame f at q."""
    for i in range(tree.parents.shape[0]):
        _world_pose(tree, i, q, oR, op)
    for f in range(frames.body.shape[0]):
        R, p = _frame_pose(frames, f, oR, op)
        _store_pose(R, p, out[f])


def _placements_one(packed, q, out):
    """One state from Python into out (nf, 4, 4), q checked in the call (status codes of dynamics.checks)."""
    tree, gravity, nq = _unpack(packed)
    frames = _unpack_frames(packed)
    nb = tree.parents.shape[0]
    if not (_config_shape_ok(tree, nq, q) and out.shape[0] == frames.body.shape[0]):
        return GENERAL
    buf = scratch(12 * nb)
    oR, o = _take(address(buf), 0, (nb, 3, 3))
    op, o = _take(address(buf), o, (nb, 3))
    _placements_into(tree, frames, q, oR, op, out)
    keep_alive(buf)
    return DONE if _finite(out) else GENERAL



@kernel
def _placement_batch(tree, Q, frames, f, out):
    """out[b] = 4x4 world placement of frame f at Q[b], computed along its support only."""
    # the arguments as views with no owner: no reference counts in the loops (dynamics._numba.borrow)
    tree, Q, frames = borrow(tree), borrow(Q), borrow(frames)
    f, out = borrow(f), borrow(out)
    nb = tree.parents.shape[0]
    path, oR, op = np.empty(nb, np.int64), np.empty((nb, 3, 3)), np.empty((nb, 3))
    n = _support(tree.parents, frames.body[f], path)
    for b in range(Q.shape[0]):
        _world_poses(tree, Q[b], path, n, oR, op)
        R, p = _frame_pose(frames, f, oR, op)
        _store_pose(R, p, out[b])


#: what :func:`_motion_batch` computes
VELOCITY, ACCELERATION, BIAS_ACCELERATION = 0, 1, 2


@kernel
def _motion_batch(tree, Q, V, A, frames, f, ref, what, classical, out):
    """out[b] = [linear; angular] velocity, acceleration or bias acceleration (a = 0, A not read) of frame f
    in reference ``ref``.  V and A have B rows or one."""
    # the arguments as views with no owner: no reference counts in the loops (dynamics._numba.borrow)
    tree, Q, V = borrow(tree), borrow(Q), borrow(V)
    A, frames, f = borrow(A), borrow(frames), borrow(f)
    ref, what, classical = borrow(ref), borrow(what), borrow(classical)
    out = borrow(out)
    parents = tree.parents
    nb = parents.shape[0]
    path, oR, op = np.empty(nb, np.int64), np.empty((nb, 3, 3)), np.empty((nb, 3))
    body = frames.body[f]
    n = _support(parents, body, path)
    Rf, pf = load33(frames.R, f), load3(frames.p, f)
    zero = (0.0, 0.0, 0.0)
    lv, la = V.shape[0] - 1, A.shape[0] - 1
    for b in range(Q.shape[0]):
        q, v, a = Q[b], V[min(b, lv)], A[min(b, la)]
        w, vl, aw, al = zero, zero, zero, zero  # the parent's motion, then body i's
        for t in range(n):
            i = path[t]
            R, p, _, _ = _world_pose(tree, i, q, oR, op)
            w, vl = motion_to_child(R, p, w, vl)
            wJ, vJ = _joint_motion(tree, i, v)
            w, vl = add(w, wJ), add(vl, vJ)
            if what != VELOCITY:
                aw, al = motion_to_child(R, p, aw, al)
                cw, cv = cross_motion(w, vl, wJ, vJ)
                aw, al = add(aw, cw), add(al, cv)
                if what == ACCELERATION:
                    sw, sv = _joint_motion(tree, i, a)
                    aw, al = add(aw, sw), add(al, sv)
        R, p = _frame_pose(frames, f, oR, op)
        fw, fv = motion_to_child(Rf, pf, w, vl)  # the frame's own motion, local axes and origin
        lin, ang = _in_reference(ref, R, p, fw, fv)
        if what != VELOCITY:
            faw, fav = motion_to_child(Rf, pf, aw, al)
            alin, aang = _in_reference(ref, R, p, faw, fav)
            if classical:
                alin = add(alin, cross(ang, lin))
            lin, ang = alin, aang
        out[b, 0], out[b, 1], out[b, 2] = lin
        out[b, 3], out[b, 4], out[b, 5] = ang


# -- public entry points ---------------------------------------------------------------------------
_placements_batch = _placements_batch
_placement_batch = _placement_batch
_motion_batch = _motion_batch
PLACEMENTS = types.float64[:, :, ::1]
_placements_single = SingleCall(_placements_one, VECTOR, PLACEMENTS)


def forward_kinematics(model, q):
    """World placement of every frame: (nframes, 4, 4), or (B, nframes, 4, 4) for a batch of q, in
    ``model.frame_names`` order (homogeneous matrices: rotation = the frame's axes in the world, translation =
    its origin)."""
    try:  # one compiled call, which checks q (a float64 vector, its length, finite values)
        out = np.empty(model.placements_shape)
        if _placements_single.call(model.packed, q, out) == DONE:
            return out
    except NOT_ARRAYS:  # not a model, or arrays of other types: the general path says what is wrong or converts
        pass
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    out = np.empty((Q.shape[0], len(model.frames), 4, 4))
    run_chunks(_placements_batch, model.tree, (Q,), (model.frame_arrays,), out)
    return out if batched else out[0]


def frame_placement(model, q, frame):
    """World placement (4, 4) of one frame (a name from ``model.frame_names`` or its index), (B, 4, 4) for a
    batch; only the frame's support is computed."""
    checks.check_model(model)
    f = checks.frame(model, frame)
    Q, batched = checks.configurations(model, q)
    out = np.empty((Q.shape[0], 4, 4))
    run_chunks(_placement_batch, model.tree, (Q,), (model.frame_arrays, f), out)
    return out if batched else out[0]


def _motion(model, q, v, a, frame, reference, what, classical=False):
    checks.check_model(model)
    f = checks.frame(model, frame)
    ref = checks.reference(reference)
    named = [("v", v, model.nv)] + ([("a", a, model.nv)] if what == ACCELERATION else [])
    Q, X, B, batched = checks.state_batch(model, q, named)
    V = X[0]
    A = X[1] if what == ACCELERATION else V[:1]
    out = np.empty((B, 6))
    run_chunks(_motion_batch, model.tree, (Q, V, A), (model.frame_arrays, f, ref, what, bool(classical)), out)
    return out if batched else out[0]


def frame_velocity(model, q, v, frame, *, reference="local_world_aligned"):
    """The frame's velocity [linear; angular] (6,) or (B, 6) in ``reference`` ("local", "local_world_aligned"
    or "world", see the module docstring); equals frame_jacobian(model, q, frame, reference=...) @ v."""
    return _motion(model, q, v, None, frame, reference, VELOCITY)


def frame_acceleration(model, q, v, a, frame, *, reference="local_world_aligned", classical=True):
    """The frame's acceleration [linear; angular] (6,) or (B, 6) in ``reference``.

    ``classical=True``: the linear part is the second time derivative of the frame origin's position (what
    differentiating a trajectory gives); ``classical=False``: the spatial acceleration (Featherstone's)."""
    return _motion(model, q, v, a, frame, reference, ACCELERATION, classical)


def frame_bias_acceleration(model, q, v, frame, *, reference="local_world_aligned"):
    """Jdot(q, v) v: the frame's classical acceleration at a = 0, [linear; angular] (6,) or (B, 6), so that the
    classical acceleration is frame_jacobian(...) @ a + frame_bias_acceleration(...) (same reference)."""
    return _motion(model, q, v, None, frame, reference, BIAS_ACCELERATION, True)
