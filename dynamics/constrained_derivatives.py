"""Analytical derivatives of constrained forward dynamics (Pinocchio's ``computeConstraintDynamicsDerivatives``,
extended to every constraint of :mod:`dynamics.constraints`: point, weld, hinge and joint coupling).

At the solution (a, lambda) of :func:`dynamics.constrained_forward_dynamics` the KKT conditions hold:

    r1 = ID(q, v, a) - J(q)^T lambda - tau = 0,
    r2 = J a + gamma + 2 alpha J v + beta^2 phi = 0      (Baumgarte's gains alpha, beta; 0, 0 for none).

Differentiating along x = q (tangent space), v, tau with (a, lambda) held in the partials:

    [M  -J^T] [da  ]     [dr1/dx]          dr1/dq = dID/dq - d(J^T lambda)/dq,  dr1/dv = dID/dv,  dr1/dtau = -1
    [J    0 ] [dlam] = - [dr2/dx],         dr2/dq, dr2/dv: the rows' derivatives at fixed a

solved like the dynamics (K = J M^-1 J^T): dlam = K^+ (Z - J M^-1 X), da = M^-1 (X + J^T dlam) with X = -dr1/dx,
Z = -dr2/dx, so that da/dtau = M^-1 - M^-1 J^T K^-1 J M^-1 and dlam/dtau = -K^-1 J M^-1.  dID/dq and dID/dv are
the RNEA derivatives (:mod:`dynamics.rnea_derivatives`) at the constrained a.

The constraint partials are taken in the world frame, on the RNEA derivatives' forward pass (per coordinate j:
J_j, dV_j, dAq_j, dAv_j, :mod:`dynamics.kinematics_derivatives`): a body b's spatial velocity and acceleration
change by dV_j + J_j x ov_b and dAq_j + dV_j x ov_b + J_j x oa_b along q_j, by J_j and dAv_j + J_j x ov_b along
v_j (j on b's support), and a point x on b moves by dx = J_j^v + J_j^w x x.  Hence, with vel = ov^v + ov^w x x
and the classical acceleration acc = oa^v + oa^w x x + ov^w x vel of an anchor:

    d vel = dov^v + dov^w x x + ov^w x dx,    d acc = doa^v + doa^w x x + oa^w x dx + dov^w x vel + ov^w x d vel

* point rows (J a + gamma = acc_A - acc_B, J v = vel_A - vel_B, phi = x_A - x_B): the differences of these;
* weld rows: alpha_A - alpha_B and w_A - w_B, and phi = log(R_A R_B^T), whose derivative is Jl^-1(phi)
  (dth_A - R_A R_B^T dth_B) (Jl the left Jacobian of SO(3)), exact off the manifold too;
* hinge rows t . (alpha_A - alpha_B) + (w_A x t) . (w_A - w_B), t . (w_A - w_B), t . (u_B x u_A), with t and
  u_A turning with body a (dt = J_j^w x t) and u_B with body b;
* coupling rows: linear in q and v (beta^2 and 2 alpha times the row).

The generalised force J^T lambda is the sum over anchors of J_b^T F with F the world spatial force at the origin
(n = x x f + torque, f): f = +-lambda_lin (body a, body b), the weld torque +-lambda_ang, the hinge torque
+-(lambda_4 t_1 + lambda_5 t_2).  Its q derivative at fixed lambda: for k on the support of b,

    d(J_k . F)/dq_j = J_k . dF/dq_j + [j on the support of k's body] F . (J_j x J_k),

dF/dq_j = (dx_j x f, 0) for j on b's support, plus (J_j^w x n_hinge, 0) for j on body a's support (t turns with
body a), J_j x J_k being how moving q_j turns the axis J_k (the tangent-space convention of the RNEA derivatives).

**Redundant rows** (K singular, lambda the minimum-norm multiplier (J^T)^+ (M a + b - tau)): the KKT solve
gives the minimum-norm dlam (K^+ on the right-hand side, as the dynamics), which misses one term of the
derivative of a pseudo-inverse where the dependency of the rows turns with q (a planar loop closed in 3-D on a
floating base: the plane's normal turns with the base): N d(J w)/dq with w = J^+ lambda and N the projector onto
null(J^T) (``null_space_term`` in the core, Golub and Pereyra 1973).  With it, dlam is the derivative of the
minimum-norm lambda wherever the rank of J stays constant nearby (a rank that changes at q has no derivative).
da is unique in every case.

Cost per state: the constrained dynamics, the RNEA derivatives, O(m nv^2) for the constraint partials and
3 nv solves with the factors of M and K (with dependent rows, one more forward pass and O(m^2 nv) for the
null-space term).  The computation is the core's (``core/constrained_derivatives.cpp``): one state in one call, a
batch over threads with the GIL released.
"""

import numpy as np

from . import _core, checks
from .constrained_dynamics import baumgarte_gains
from .constraints import arrays, core_constraints, run_core
from .errors import InputError


def model_has_constraints(model):
    """Whether ``model`` (if it is one) declares constraints: the single call's fast path is for those only."""
    return bool(getattr(model, "constraints", None))


def constrained_forward_dynamics_derivatives(model, q, v, tau, *, baumgarte=None, gravity=None):
    """(da_dq, da_dv, da_dtau, dlam_dq, dlam_dv, dlam_dtau): the partial derivatives of
    ``a, lam = constrained_forward_dynamics(model, q, v, tau, baumgarte=..., gravity=...)`` (analytical, module
    docstring), as Pinocchio's computeConstraintDynamicsDerivatives (ddq_dq, ddq_dv, ddq_dtau, dlambda_dq,
    dlambda_dv, dlambda_dtau).

    q derivatives are in the tangent space (nv columns, as :func:`inverse_dynamics_derivatives`).  The a blocks
    are (nv, nv), the lam blocks (m, nv), with a leading B for a batch; lam's rows are those of
    :mod:`dynamics.constraints` (world axes).  Redundant rows: dlam is the derivative of the minimum-norm lam
    where the rank of the rows stays constant nearby (module docstring).
    Raises InputError on a model without constraints, for bad inputs (naming the argument) and when M is
    singular (naming the joint).
    """
    alpha, beta = baumgarte_gains(baumgarte)
    if gravity is None and model_has_constraints(model):  # one state: one core call, which checks q, v and tau
        try:
            out = _core.constrained_forward_dynamics_derivatives(model.core, core_constraints(model), q, v, tau, alpha,
                                                                  beta)
            if out is not None:
                a, lam = out[:, :model.nv], out[:, model.nv:]
                return a[0], a[1], a[2], lam[0], lam[1], lam[2]
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    checks.check_model(model)
    C, m = arrays(model)
    if m == 0:
        raise InputError("model: has no constraints; constrained_forward_dynamics_derivatives differentiates the "
                         "dynamics of a model with constraints (dynamics.with_constraints); for an open tree use "
                         "forward_dynamics_derivatives")
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    g = checks.gravity_vector(model, gravity)
    nv = model.nv
    out = np.empty((B, 3, nv + m, nv))
    failed, body = run_core(_core.constrained_forward_dynamics_derivatives_batch, model, Q, V, T, g, alpha, beta,
                            out=out)
    if failed >= 0:
        raise checks.singular_joint_error(model, body, "constrained forward dynamics derivatives")
    if not batched:
        out = out[0]
    a, lam = out[..., :nv, :], out[..., nv:, :]
    i = (slice(None),) if batched else ()
    return (a[i + (0,)], a[i + (1,)], a[i + (2,)], lam[i + (0,)], lam[i + (1,)], lam[i + (2,)])
