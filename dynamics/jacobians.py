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
from ._numba import inline_kernel
from .checks import REFERENCES
from .kinematics import LOCAL, WORLD, _frame_pose, _support, _world_poses
from .parallel import run
from .spatial import add, cross, load3, load33, rot, rotT

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


# -- numba kernels that the operational-space controller still calls (until it moves to the core) --------------

@inline_kernel
def _jacobian_into(tree, frames, q, f, ref, point, path, oR, op, J):
    """J (6, nv) of frame f at q in reference ``ref``, at ``point`` (frame axes) from the frame origin.
    Only the support's columns are written: J must be zero elsewhere.  Returns the frame's world pose.
    Inlined: called as a function from J M^-1 J^T's batch it cost that kernel ~30 % (0.7 us per state)."""
    S, v_idx, nv_j = tree.S, tree.v_idx, tree.nv_j
    n = _support(tree.parents, frames.body[f], path)
    _world_poses(tree, q, path, n, oR, op)
    Rf, pf = _frame_pose(frames, f, oR, op)
    o = add(pf, rot(Rf, point))
    for t in range(n):
        i = path[t]
        R, p = load33(oR, i), load3(op, i)
        x = (-p[0], -p[1], -p[2]) if ref == WORLD else (o[0] - p[0], o[1] - p[1], o[2] - p[2])
        for k in range(v_idx[i], v_idx[i] + nv_j[i]):
            w = rot(R, (S[k, 0], S[k, 1], S[k, 2]))
            v = add(rot(R, (S[k, 3], S[k, 4], S[k, 5])), cross(w, x))
            if ref == LOCAL:
                w, v = rotT(Rf, w), rotT(Rf, v)
            J[0, k], J[1, k], J[2, k] = v
            J[3, k], J[4, k], J[5, k] = w
    return Rf, pf


