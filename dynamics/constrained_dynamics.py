"""Constrained forward and inverse dynamics: the KKT system of a closed-loop or coupled mechanism.

With the constraint rows of :mod:`dynamics.constraints` (phi, Phi_q = J, gamma = Phi_q_dot v) the lectures'
equations of a parallel mechanism are

    M a + C v + g = tau + J^T lambda,        J a + gamma = -(2 alpha J v + beta^2 phi)

(the right-hand side: Baumgarte's stabilisation phi_dd + 2 alpha phi_d + beta^2 phi = 0, zero without it).
Eliminating a with f = tau - C v - g (the lectures' formula):

    K = J M^-1 J^T (the Delassus matrix),   K lambda = -(J M^-1 f + gamma + 2 alpha J v + beta^2 phi),
    a = M^-1 (f + J^T lambda).

M comes from the CRBA and is factored M = L^T L with no fill-in (Featherstone 2008, sec. 6.5: L[k, c] != 0
only where coordinate c is k or an ancestor of k), so that with Y = (L^-T J^T)^T (m, nv): K = Y Y^T,
J M^-1 f = Y (L^-T f), a = L^-1 (L^-T f + Y^T lambda); C v + g from the RNEA at a = 0.  Measured
(benchmarks/constraints.py): the CRBA and a factor cost less than the O(n^2) articulated-body M^-1 of
:mod:`dynamics.minverse`, which the first version used; the L^T L factor rather than a dense Cholesky
because a branched tree's M is sparse (the Stewart platform's is block diagonal: 1.2 us against 1.8 us per
state, K 2 us against 4 us), at ~0.1 us more on a floating chain.

Redundant rows are normal (a planar loop closed by a 3-D point or hinge closure, a closure declared twice): K
is then singular, a stays unique, and lambda is the minimum-norm multiplier lambda = K^+ rhs.  A Cholesky
factor of K serves when its pivots stay above :data:`CHOLESKY_RTOL`; otherwise Cholesky with diagonal
pivoting stops at the rank (the pivots left below :data:`RANK_RTOL` times K's largest diagonal entry are the
round-off of exactly dependent rows, ~1e-16 relative) and the minimum-norm solution follows from the r x r
Gram matrix of the factor (:func:`_pinv_solve`): no eigen-decomposition, no allocation.  It equals K^+ rhs for
a right-hand side in K's range, which a closed loop's is (J M^-1 f and J v lie in J's range, and dependent
rows have dependent gamma and phi); the tests compare it with numpy's pinv(K) rhs and with the even split
of a closure declared twice, to 1e-9 relative.
lambda's rows and frames are those of :mod:`dynamics.constraints` (world axes, force on body a at its
anchor, torques, coupling forces).

The simulation's constrained right-hand side, drift and projections are the core's
(``core/constrained_dynamics.hpp``, ``core/simulation/constrained_problem.cpp``), on the same equations.
"""

import numpy as np

from . import _core, checks
from .constraints import arrays, core_constraints, run_core
from .errors import InputError

#: pivots of K's pivoted Cholesky factor below this times K's largest diagonal entry are dependent rows
RANK_RTOL = 1e-12
#: a Cholesky pivot of K below this times K's largest diagonal entry sends the solve to the pivoted factor
CHOLESKY_RTOL = 1e-10
#: default Baumgarte gains of a simulation (1/s): a critically damped phi_dd + 2 alpha phi_d + beta^2 phi = 0
DEFAULT_BAUMGARTE = (10.0, 10.0)


# -- public entry points -----------------------------------------------------------------------------------------
class _Failed(Exception):
    def __init__(self, state, code):
        self.state, self.code = state, code


def _singular(model, what, e):
    return InputError(f"{what}: the mass matrix is singular at joint {model.joint_names[e.code]!r}: it moves no "
                      f"mass or inertia (lock it with dynamics.lock_joints, or add mass below it)")


def baumgarte_gains(baumgarte):
    """(alpha, beta) from None (no stabilisation) or a pair of finite numbers >= 0 (1/s)."""
    if baumgarte is None:
        return 0.0, 0.0
    try:
        alpha, beta = baumgarte
    except (TypeError, ValueError):
        raise InputError(f"baumgarte: expected None or (alpha, beta) in 1/s, got {baumgarte!r}") from None
    return (checks.real_number("baumgarte alpha", alpha, lo=0.0), checks.real_number("baumgarte beta", beta, lo=0.0))


def constrained_forward_dynamics(model, q, v, tau, *, baumgarte=None, gravity=None):
    """Accelerations and multipliers of a constrained model: (a, lam), (nv,) and (m,), or (B, nv) and (B, m).

    Solves M a + C v + g = tau + Phi_q^T lam with Phi_q a + Phi_q_dot v = -(2 alpha Phi_q v + beta^2 phi)
    (``baumgarte=(alpha, beta)`` in 1/s; None: no stabilisation).  lam: minimum-norm multipliers in physical
    units, the rows and frames of :mod:`dynamics.constraints` (world axes; force on frame_a's body at its
    anchor [N], torques [N m], coupling generalised forces).  A model without constraints gives the ABA's a.
    The solve is the core's (``core/constrained_dynamics.cpp``).
    """
    alpha, beta = baumgarte_gains(baumgarte)
    if gravity is None:  # one state: one core call, which checks q, v and tau itself
        try:
            out = _core.constrained_forward_dynamics(model.core, core_constraints(model), q, v, tau, alpha, beta)
            if out is not None:
                return out
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    checks.check_model(model)
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    m = arrays(model)[1]
    out = np.empty((B, model.nv + m))
    failed, body = run_core(_core.constrained_forward_dynamics_batch, model, Q, V, T,
                            checks.gravity_vector(model, gravity), alpha, beta, out=out)
    if failed >= 0:
        raise _singular(model, "constrained forward dynamics", _Failed(failed, body))
    a, lam = out[:, :model.nv], out[:, model.nv:]
    return (a, lam) if batched else (a[0], lam[0])


def project_velocity(model, q, v):
    """The velocity closest to v (kinetic-energy metric) that satisfies Phi_q v = 0: (nv,) or (B, nv)."""
    checks.check_model(model)
    Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = np.empty((B, model.nv))
    failed, body = run_core(_core.project_velocity_batch, model, Q, V, out=out)
    if failed >= 0:
        raise _singular(model, "project_velocity", _Failed(failed, body))
    return out if batched else out[0]


def _actuated_mask(model, actuated):
    if isinstance(actuated, str) or not hasattr(actuated, "__iter__"):
        raise InputError(f"actuated: expected a list of joint names, got {actuated!r}")
    mask = np.zeros(model.nv)
    for name in actuated:
        if not isinstance(name, str):
            raise InputError(f"actuated: expected joint names (str), got {name!r}")
        mask[model.v_slice(name)] = 1.0
    return mask


def constrained_inverse_dynamics(model, q, v, a, *, actuated, gravity=None):
    """Torques of the ``actuated`` joints (names) that produce the motion (q, v, a) of a constrained model: tau
    (nv,) or (B, nv), zero at passive joints, with M a + C v + g = tau + Phi_q^T lam for some lam.

    With more actuators than the mechanism's mobility, tau is the minimum-norm choice.  Raises InputError when
    a violates the constraints (Phi_q a + Phi_q_dot v != 0) or when the actuated joints cannot produce it (too
    few, or placed where the loops take their torque), naming the state.
    """
    Q, (V, A), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("a", a, model.nv)))
    mask = _actuated_mask(model, actuated)
    out = np.empty((B, model.nv))
    failed, code = run_core(_core.constrained_inverse_dynamics_batch, model, Q, V, A,
                            checks.gravity_vector(model, gravity), mask, out=out)
    if failed >= 0:
        where = f" (state {failed})" if batched else ""
        if code == 1:
            raise InputError(f"a{where}: violates the constraints (Phi_q a + Phi_q_dot v != 0); constrained "
                             f"motions satisfy them, e.g. the a of constrained_forward_dynamics")
        names = [model.joint_names[i] for i in range(model.nbodies) if mask[model.v_index[i]]]
        raise InputError(f"actuated{where}: the joints {names} cannot produce this motion of the constrained "
                         f"mechanism (too few actuators for its {model.info.get('constraints', {}).get('mobility', '?')}"
                         f" degrees of freedom, or torques the loops absorb); actuate other joints")
    return out if batched else out[0]
