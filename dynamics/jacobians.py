"""Frame Jacobians (Featherstone 2008, sec. 4.3; Pinocchio's computeFrameJacobian).

J maps joint velocities to the frame's velocity, frame_velocity = J(q) v, with rows [linear; angular].  Column
k (a velocity coordinate of joint i on the frame's support; every other column is zero) is the motion
subspace S_k of body i carried to the world:

    w_k = oR_i S_k^w,    v_k(x) = oR_i S_k^v + w_k x (x - op_i)    (the velocity of the world point x)

then expressed in the reference (:mod:`dynamics.kinematics`): "world" takes x = 0 (the spatial column at the
world origin); "local_world_aligned" takes x = o, the frame origin moved by ``point`` (given in the frame's
axes: a point fixed on the frame's body); "local" rotates that column into the frame's axes, oR_f^T.
A point does not change the "world" Jacobian: the spatial velocity of a body is the same at all its points.

The algorithm is the core's (``core/jacobians.cpp``); this module checks the arguments and calls it.
"""

import numpy as np

from . import _core, checks
from .checks import REFERENCES
from .parallel import run

_ORIGIN = np.zeros(3)


def frame_jacobian(model, q, frame, *, reference="local_world_aligned", point=None):
    """The frame's Jacobian (6, nv), or (B, 6, nv) for a batch of q: rows [linear; angular].

    ``reference``: "local_world_aligned" (the frame origin's velocity and the angular velocity, world axes),
    "local" (the same in the frame's axes) or "world" (the spatial Jacobian at the world origin): Pinocchio's
    three, same meaning.  ``point``: (3,) offset of a point fixed on the frame, in the frame's axes; the
    linear rows are then that point's velocity (the "world" Jacobian does not depend on it).
    """
    if point is None:  # at the frame origin: one core call, which checks q, the frame and the reference
        try:
            f = model.frame_lookup.get(frame, -1)  # a name; an index only as an int (not True, not 1.0)
            if f < 0 and type(frame) is int and 0 <= frame < len(model.frames):
                f = frame
            J = _core.frame_jacobian(model.core, q, f, REFERENCES.get(reference, -1))
            if J is not None:
                return J
        except checks.NOT_A_MODEL:  # not a model; an unhashable frame or reference: the general path says what
            pass
    checks.check_model(model)
    f = checks.frame(model, frame)
    ref = checks.reference(reference)
    pt = _ORIGIN if point is None else checks.vector("point", point, 3)
    Q, batched = checks.configurations(model, q)
    out = run(_core.frame_jacobian_batch, model, Q, f, ref, pt, out=np.empty((Q.shape[0], 6, model.nv)))
    return out if batched else out[0]
