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

The algorithms are the core's (``core/kinematics.cpp``); this module checks the arguments and calls them.
"""

import numpy as np

from . import _core, checks
from ._numba import borrow, inline_kernel, kernel
from .joints import _joint_motion, _joint_transform
from .model import FRAME_BODY, FRAME_SHIFTED, FRAME_WORLD
from .parallel import run
from .spatial import add, cross, cross_motion, load3, load33, matmul, motion_to_child, rot, store3, store33

WORLD, LOCAL, LOCAL_WORLD_ALIGNED = (checks.REFERENCES[k] for k in ("world", "local", "local_world_aligned"))
#: what a frame motion computes (core/kinematics.hpp's FrameMotion)
VELOCITY, ACCELERATION, BIAS_ACCELERATION = 0, 1, 2


def forward_kinematics(model, q):
    """World placement of every frame: (nframes, 4, 4), or (B, nframes, 4, 4) for a batch of q, in
    ``model.frame_names`` order (homogeneous matrices: rotation = the frame's axes in the world, translation =
    its origin)."""
    try:  # one core call, which checks q (a float64 vector, its length, finite values)
        out = _core.placements(model.core, q)
        if out is not None:
            return out
    except checks.NOT_A_MODEL:  # the general path says what is wrong
        pass
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    out = run(_core.placements_batch, model, Q, out=np.empty((Q.shape[0], len(model.frames), 4, 4)))
    return out if batched else out[0]


def frame_placement(model, q, frame):
    """World placement (4, 4) of one frame (a name from ``model.frame_names`` or its index), (B, 4, 4) for a
    batch; only the frame's support is computed."""
    checks.check_model(model)
    f = checks.frame(model, frame)
    Q, batched = checks.configurations(model, q)
    out = run(_core.frame_placement_batch, model, Q, f, out=np.empty((Q.shape[0], 4, 4)))
    return out if batched else out[0]


def _motion(model, q, v, a, frame, reference, what, classical=False):
    checks.check_model(model)
    f = checks.frame(model, frame)
    ref = checks.reference(reference)
    named = [("v", v, model.nv)] + ([("a", a, model.nv)] if what == ACCELERATION else [])
    Q, X, B, batched = checks.state_batch(model, q, named)
    V = X[0]
    A = X[1] if what == ACCELERATION else V[:1]
    out = run(_core.frame_motion_batch, model, Q, V, A, f, ref, what, bool(classical), out=np.empty((B, 6)))
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


# -- numba kernels that the constraints, contact and the operational-space controller still call (until they move
# to the core) -------------------------------------------------------------------------------------------------

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


