"""Forward dynamics by the Articulated Body Algorithm, O(n) (Featherstone 2008, sec. 7.3, Table 7.1).

    a = M(q)^-1 (tau - C(q, v) v - g(q) + J^T f_ext)

Pass 1 (forward): v_i = X_i v_p + S_i qd_i,  c_i = v_i x (S_i qd_i),  I^A_i = I_i,
                  p^A_i = v_i x* I_i v_i - f_ext_i.
Pass 2 (reverse): U_i = I^A_i S_i,  D_i = S_i^T U_i,  u_i = tau_i - S_i^T p^A_i,
                  I^a = I^A_i - U_i D_i^-1 U_i^T,  p^a = p^A_i + I^a c_i + U_i D_i^-1 u_i,
                  I^A_p += X_i^T I^a X_i,  p^A_p += X_i^T p^a.
Pass 3 (forward): a'_i = X_i a_p + c_i (a_0 = (0, -g)),  qdd_i = D_i^-1 (u_i - U_i^T a'_i),
                  a_i = a'_i + S_i qdd_i.

6x6 inertias are in (angular, linear) order in each body's frame.  A joint whose D_i is not positive (it
carries no mass or inertia it could move) makes M singular: the kernel stops and returns that body's index.

The algorithm is the core's (``core/aba.cpp``); this module checks the arguments and calls it.
"""

import numpy as np

from . import _core, checks
from .constrained_dynamics import constrained_forward_dynamics
from .parallel import run
from .rnea import bias_forces, inverse_dynamics


def refuse_singular(model, q, what):
    """Raise :func:`~dynamics.checks.singular_joint_error` when the mass matrix is singular at q: the
    articulated-body pivot D = S^T I^A S of some joint is not positive definite.  The rule ``simulate`` applies to
    q0 and ``dynamics check`` to the neutral configuration, so both say the same."""
    zero = np.zeros((1, model.nv))
    run(_core.aba_batch, model, np.ascontiguousarray(q, dtype=float).reshape(1, model.nq), zero, zero, checks.external_forces(model, None, 1),
        np.zeros(3), False, out=np.empty((1, model.nv)), singular=what)


def forward_dynamics(model, q, v, tau, *, gravity=None, f_ext=None):
    """Joint accelerations a = M^-1 (tau - C v - g + J^T f_ext) by the ABA, O(n).

    Shapes as :func:`dynamics.inverse_dynamics` with tau in place of a.  Raises InputError naming the
    joint when the mass matrix is singular (a joint that moves no mass or inertia).

    On a constrained model (``model.constraints``: loops, a gripper's mimic couplings) the accelerations honour
    the constraints: the ``a`` of :func:`dynamics.constrained_forward_dynamics` without Baumgarte terms (use that
    function for the multipliers or stabilisation), with f_ext entering as its generalised force J^T f_ext.
    """
    if getattr(model, "constraints", None):
        return _constrained(model, q, v, tau, gravity, f_ext)
    if gravity is None and f_ext is None:  # one state: one core call, which checks q, v and tau itself
        try:
            qdd = _core.aba(model.core, q, v, tau)
            if qdd is not None:
                return qdd
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    checks.check_model(model)
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    out = run(_core.aba_batch, model, Q, V, T, F, g, bool(V.any()), out=np.empty((B, model.nv)),
              singular="forward dynamics")
    return out if batched else out[0]


def _constrained(model, q, v, tau, gravity, f_ext):
    """forward_dynamics on a constrained model.  f_ext's generalised force J^T f_ext is read off the RNEA:
    ID(q, v, 0) - ID(q, v, 0, f_ext) (the same gravity in both, so it cancels)."""
    if f_ext is not None:
        ext = bias_forces(model, q, v, gravity=gravity) - inverse_dynamics(model, q, v, np.zeros(model.nv),
                                                                          gravity=gravity, f_ext=f_ext)
        tau = np.asarray(tau, dtype=float)
        if tau.shape[-1:] == (model.nv,):  # (otherwise constrained_forward_dynamics names the bad shape)
            tau = tau + ext
    return constrained_forward_dynamics(model, q, v, tau, gravity=gravity)[0]
