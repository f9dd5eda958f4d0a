"""Analytical derivatives of inverse dynamics (Carpentier and Mansard, "Analytical derivatives of rigid body
dynamics algorithms", RSS 2018; Pinocchio's ``computeRNEADerivatives``).

    tau = RNEA(q, v, a) = M(q) a + C(q, v) v + g(q) - sum_i J_i^T f_ext_i
    dtau/dq (in the tangent space), dtau/dv, dtau/da = M

Everything is expressed in the world frame (motions and forces at the world origin), so that moving a joint
moves its whole subtree rigidly.  A q derivative is taken along q (+) dq with dq in the joint's own frame
(the local tangent, as :func:`dynamics.integrate` and Pinocchio): the column of a joint's coordinate k is the
world motion J_k = oX_i S_k of its axis.

Forward pass (root out; p the parent of body i, ov_0 = 0, oa_0 = (0, -g)):

    J_k    = oX_i S_k                          (world axes of joint i)
    ov_i   = ov_p + J_i qd_i,     oa_i = oa_p + J_i qdd_i + ov_i x (J_i qd_i)
    dV_k   = ov_p x J_k           the world velocity change of the subtree along a q_k move, rigid part taken out
    dAq_k  = oa_p x J_k + ov_p x dV_k,      dAv_k = ov_i x J_k + dV_k
    f_i    = I_i oa_i + ov_i x* I_i ov_i - oX_i^-T f_ext_i          (I_i the body inertia in the world frame)
    dY_i   = ov_i x* I_i - I_i ov_i x + (h_i x*-matrix) = [[B_i, 0], [-2 [hf_i], 0]]
             with h_i = (hn_i, hf_i) = I_i ov_i and B_i = [w] Io - Io [w] - [vl][h] - [h][vl] - [hn]

Backward pass (leaves in), with composites Y_i = sum of I over the subtree of i, dY_i likewise, F_i = sum of f:

    tau_k = J_k^T F_i
    Fa_k = Y_i J_k,   Fv_k = dY_i J_k + Y_i dAv_k,   Fq_k = dY_i dV_k + Y_i dAq_k
    rows r of i or of an ancestor, columns k of i:  M[r, k] = J_r^T Fa_k,  dtau_r/dv_k = J_r^T Fv_k,
        dtau_r/dq_k = J_r^T Fq_k, where for r above i Fq_k also carries J_k x* F_i (the rigid motion of the
        subtree's forces; at r in i it cancels with the motion of J_r itself)
    rows k of i, columns c of a strict ancestor:  dtau_k/dv_c = (Y_i J_k)^T dAv_c + (dY_i^T J_k)^T J_c,
        dtau_k/dq_c = (Y_i J_k)^T dAq_c + (dY_i^T J_k)^T dV_c

Cost: O(n d) for n coordinates at tree depth d (the ancestor walk), as Pinocchio.

The public function is the core's (``core/rnea_derivatives.cpp``); this module checks the arguments and calls it.
"""


import numpy as np

from . import _core, checks
from .parallel import run


def inverse_dynamics_derivatives(model, q, v, a, *, gravity=None, f_ext=None):
    """(dtau_dq, dtau_dv, M): the partial derivatives of tau = inverse_dynamics(model, q, v, a) (analytical,
    Carpentier and Mansard 2018; module docstring).

    dtau_dq is taken in the tangent space (nv columns; a floating base's along q (+) dq with dq in its body
    frame, as :func:`dynamics.integrate` and Pinocchio); dtau_da = M(q).  Inputs as
    :func:`dynamics.inverse_dynamics`; each result is (nv, nv), or (B, nv, nv) for a batch.
    """
    if gravity is None and f_ext is None:  # one state: one core call, which checks q, v and a itself
        try:
            out = _core.rnea_derivatives(model.core, q, v, a)
            if out is not None:
                return out
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    checks.check_model(model)
    Q, (V, A), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("a", a, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    out = run(_core.rnea_derivatives_batch, model, Q, V, A, F, g, out=np.empty((B, 3, model.nv, model.nv)))
    if batched:
        return out[:, 0], out[:, 1], out[:, 2]
    return out[0, 0], out[0, 1], out[0, 2]
