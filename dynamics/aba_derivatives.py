"""Analytical derivatives of forward dynamics (Carpentier and Mansard, RSS 2018; Pinocchio's
``computeABADerivatives``).

    a = ABA(q, v, tau) = M(q)^-1 (tau - C(q, v) v - g(q) + J^T f_ext)

Differentiating M(q) a + b(q, v) = tau at a fixed tau (the identity RNEA(q, v, ABA(q, v, tau)) = tau):

    da/dq = -M^-1 dtau/dq (q, v, a),    da/dv = -M^-1 dtau/dv (q, v, a),    da/dtau = M^-1

with dtau/dq, dtau/dv the RNEA derivatives (:mod:`dynamics.rnea_derivatives`) evaluated at the ABA's
acceleration.  q derivatives are in the tangent space (nv columns, along q (+) dq with dq in each joint's
frame), as Pinocchio's.

The public function is the core's (``core/aba_derivatives.cpp``): the ABA, M^-1 and the RNEA derivatives at
the ABA's acceleration, then the two products; this module checks the arguments and calls it.

The core's kernel (``core/aba_derivatives.cpp``) runs the ABA in the body frame (the one ``forward_dynamics``
runs, so the acceleration it differentiates at is the same bits), then four passes over the tree sharing what each
computes:

1. forward: one world pass from the ABA's joint transforms: world poses, axes, velocities and the RNEA
   derivatives' velocity part, each body's inertia about the world origin;
2. backward: M^-1's rows and the articulated inertias (``core/minverse_passes.cpp``, the steps of
   :mod:`dynamics.minverse`);
3. backward: the RNEA derivatives' composites and their blocks at the ABA's acceleration (no M: it is not needed);
4. forward: M^-1's columns;

then one product da/dq = -M^-1 dtau/dq, da/dv = -M^-1 dtau/dv that skips the zero blocks between branches, each
entry summed in the textbook order (the same bits as the plain loop), in one workspace per thread
(``core/derivatives_data.hpp``).
"""


import numpy as np

from . import _core, checks
from .errors import InputError
from .parallel import run


def forward_dynamics_derivatives(model, q, v, tau, *, gravity=None, f_ext=None):
    """(da_dq, da_dv, Minv): the partial derivatives of a = forward_dynamics(model, q, v, tau) (analytical,
    module docstring); da/dtau = Minv = M(q)^-1.

    da_dq is taken in the tangent space (nv columns, as :func:`inverse_dynamics_derivatives`).  Inputs as
    :func:`dynamics.forward_dynamics` on a model without constraints; each result is (nv, nv), or (B, nv, nv)
    for a batch.  Raises InputError naming the joint when M is singular, and on a model with constraints
    (whose accelerations are not the ABA's).
    """
    if getattr(model, "constraints", None):
        raise InputError("model: forward_dynamics_derivatives differentiates the unconstrained dynamics; this "
                         "model has constraints (differentiate the model without them, or its constrained "
                         "dynamics with constrained_forward_dynamics_derivatives)")
    if gravity is None and f_ext is None:  # one state: one core call, which checks q, v and tau itself
        try:
            out = _core.aba_derivatives(model.core, q, v, tau)
            if out is not None:
                return out
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    checks.check_model(model)
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    out = run(_core.aba_derivatives_batch, model, Q, V, T, F, g, out=np.empty((B, 3, model.nv, model.nv)),
              singular="forward dynamics derivatives")
    if batched:
        return out[:, 0], out[:, 1], out[:, 2]
    return out[0, 0], out[0, 1], out[0, 2]
