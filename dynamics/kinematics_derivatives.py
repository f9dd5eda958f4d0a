"""Derivatives of frame kinematics and of the centre of mass (Pinocchio's computeForwardKinematicsDerivatives,
getFrameVelocityDerivatives, getFrameAccelerationDerivatives, getFrameJacobianTimeVariation,
getCenterOfMassVelocityDerivatives).

The forward pass of the RNEA derivatives (:mod:`dynamics.rnea_derivatives`, without gravity) gives, in the world
frame at the world origin, per velocity coordinate k of joint j: its axis J_k, and the changes of the subtree's
velocity and acceleration that are not the rigid motion of the subtree, dV_k = ov_p x J_k,
dAq_k = oa_p x J_k + ov_p x dV_k, dAv_k = ov_j x J_k + dV_k.  For a frame on body b and k on b's support (other columns are zero), with ov_b, oa_b
the body's spatial velocity and acceleration:

    d ov_b / dq_k = dV_k + J_k x ov_b,          d ov_b / dv_k = J_k
    d oa_b / dq_k = dAq_k + dV_k x ov_b + J_k x oa_b,   d oa_b / dv_k = dAv_k + J_k x ov_b,   d oa_b / da_k = J_k
    d J_k / dt = ov_j x J_k                                     (the "world" Jacobian's time variation)

In the frame's references (:mod:`dynamics.kinematics`): "world" is the above; "local" applies oX_f^-1 to it
after taking out the frame's own motion J_k x (.) (a rigid motion moves the frame too):
d(oX_f^-1 ov)/dq_k = oX_f^-1 dV_k; "local_world_aligned" is the motion at the frame origin o_f in world axes,
(w, v - o_f x w), whose q derivative also carries the origin's own motion do_f/dq_k = J_k^v + J_k^w x o_f.
Accelerations are spatial (Featherstone's, ``classical=False`` in :func:`dynamics.frame_acceleration`), as
Pinocchio's derivatives.  A frame placement's derivative is the frame Jacobian itself: oM_f(q (+) dq) =
oM_f Exp(J_local dq).

Centre of mass (mass M, c_i the centre of body i, P_j and H_j the subtree sums of m_i dc_i/dt and m_i c_i, m_j
the subtree's mass): d com/dq = Jcom and

    M d(vcom)/dq_k = J_k^w x P_j + m_j dV_k^v + dV_k^w x H_j.

One state per call, in the core (``core/kinematics_derivatives.cpp``); this module checks the arguments and calls
it.
"""

import numpy as np

from . import _core, checks

_REFS = ("world", "local", "local_world_aligned")


def _frame_state(model, q, v, a, frame, reference):
    """The checked (frame index, q, v, a, reference code) of one state (a None: not needed)."""
    checks.check_model(model)
    f = checks.frame(model, frame)
    if reference not in _REFS:
        raise checks.InputError(f"reference: expected one of {list(_REFS)}, got {reference!r}")
    q = checks.vector("q", q, model.nq)
    v = checks.vector("v", v, model.nv)
    a = None if a is None else checks.vector("a", a, model.nv)
    return f, q, v, a, checks.reference(reference)


def frame_velocity_derivatives(model, q, v, frame, *, reference="local_world_aligned"):
    """(dv_dq, dv_dv), each (6, nv): the derivatives of frame_velocity(model, q, v, frame, reference=...)
    ([linear; angular]) with respect to q (tangent space) and v (module docstring).  One state."""
    f, q, v, _, ref = _frame_state(model, q, v, None, frame, reference)
    out = np.empty((2, 6, model.nv))
    _core.frame_velocity_derivatives(model.core, q, v, f, ref, out[0], out[1])
    return out[0], out[1]


def frame_acceleration_derivatives(model, q, v, a, frame, *, reference="local_world_aligned"):
    """(dv_dq, da_dq, da_dv, da_da), each (6, nv): the derivatives of the frame's velocity and of its spatial
    acceleration (frame_acceleration(..., classical=False)) with respect to q (tangent space), v and a, as
    Pinocchio's getFrameAccelerationDerivatives.  One state."""
    f, q, v, a, ref = _frame_state(model, q, v, a, frame, reference)
    out = np.empty((4, 6, model.nv))
    _core.frame_acceleration_derivatives(model.core, q, v, a, f, ref, *out)
    return tuple(out)

def frame_jacobian_time_variation(model, q, v, frame, *, reference="local_world_aligned"):
    """dJ/dt (6, nv) of frame_jacobian(model, q, frame, reference=...) moving with velocity v (Pinocchio's
    getFrameJacobianTimeVariation): J a + dJ/dt v = d/dt (J v), which is frame_acceleration(...) in
    "local_world_aligned" (classical) and frame_acceleration(..., classical=False) in "local" and "world".  One
    state.  The core's (``core/jacobians.cpp``)."""
    checks.check_model(model)
    f = checks.frame(model, frame)
    if reference not in _REFS:
        raise checks.InputError(f"reference: expected one of {list(_REFS)}, got {reference!r}")
    q = checks.vector("q", q, model.nq)
    v = checks.vector("v", v, model.nv)
    out = np.empty((6, model.nv))
    _core.frame_jacobian_time_variation(model.core, q, v, f, checks.reference(reference), out)
    return out


def center_of_mass_derivatives(model, q, v):
    """(dcom_dq, dvcom_dq), each (3, nv), world frame: the derivatives of center_of_mass(model, q) (= Jcom) and
    of center_of_mass_velocity(model, q, v) with respect to q (tangent space; module docstring).  One state."""
    checks.check_model(model)
    q = checks.vector("q", q, model.nq)
    v = checks.vector("v", v, model.nv)
    out = np.empty((2, 3, model.nv))
    _core.center_of_mass_derivatives(model.core, q, v, out[0], out[1])
    return out[0], out[1]
