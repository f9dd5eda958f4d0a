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

The algorithm is the core's (``core/com.cpp``); this module checks the arguments and calls it.
"""

import numpy as np

from . import _core, checks
from .parallel import run

COM, VELOCITY, JACOBIAN = 0, 1, 2  # core/com.hpp's ComQuantity


def _run(model, q, v, what):
    checks.check_model(model)
    if v is None:
        Q, batched = checks.configurations(model, q)
        V, B = Q[:1, :0], Q.shape[0]
    else:
        Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = run(_core.center_of_mass_batch, model, Q, V, what,
              out=np.empty((B, 3, model.nv if what == JACOBIAN else 1)))
    if what != JACOBIAN:
        out = out[:, :, 0]
    return out if batched else out[0]


def center_of_mass(model, q):
    """The robot's centre of mass in the world, (3,) or (B, 3) (``model.total_mass`` is its mass)."""
    try:  # one state: one core call, which checks q (anything else takes the general path)
        out = _core.center_of_mass(model.core, q, False)
        if out is not None:
            return out
    except checks.NOT_A_MODEL:
        pass
    return _run(model, q, None, COM)


def center_of_mass_velocity(model, q, v):
    """The velocity of the centre of mass in the world, (3,) or (B, 3)."""
    return _run(model, q, v, VELOCITY)


def com_jacobian(model, q):
    """Jcom (3, nv) or (B, 3, nv), world frame: center_of_mass_velocity = Jcom v."""
    try:  # the fast path, as in center_of_mass
        out = _core.center_of_mass(model.core, q, True)
        if out is not None:
            return out
    except checks.NOT_A_MODEL:
        pass
    return _run(model, q, None, JACOBIAN)
