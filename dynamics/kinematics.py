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
from .parallel import run

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
