"""Inverse dynamics by the Recursive Newton-Euler Algorithm (Featherstone 2008, sec. 5.3, Table 5.1).

    tau = M(q) a + C(q, v) v + g(q) - sum_i J_i^T f_ext_i

Body-frame formulation.  Gravity enters as a fictitious upward acceleration of the world, a_0 = (0, -g).
Forward pass, for each body i with parent p and joint velocity v_J = S_i qd_i:

    v_i = X_i v_p + S_i qd_i
    a_i = X_i a_p + S_i qdd_i + v_i x (S_i qd_i)
    f_i = I_i a_i + v_i x* I_i v_i - f_ext_i

Backward pass:  tau_i = S_i^T f_i ,  f_p += X_i^T f_i .

The algorithm is the core's (``core/rnea.cpp``); this module checks the arguments and calls it.
"""


import numpy as np

from . import _core, checks
from .parallel import run


def _run(model, q, v, a, gravity, f_ext):
    """The general path: any batch, gravity or external forces; every argument checked and converted."""
    checks.check_model(model)
    Q, (V, A), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("a", a, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    with_v, with_a = bool(V.any()), bool(A.any())  # zero terms are skipped, not computed
    out = run(_core.rnea_batch, model, Q, V, A, F, g, with_v, with_a, out=np.empty((B, model.nv)))
    return out if batched else out[0]


def skipped_terms(v=None, a=None, gravity=(0.0, 0.0, -9.81)):
    """Names of the terms a call with these inputs does not compute (for scene reports)."""
    out = []
    if v is None or not np.any(v):
        out.append("velocity products")
    if a is None or not np.any(a):
        out.append("joint accelerations")
    if gravity is not None and not np.any(gravity):
        out.append("gravity")
    return out


def inverse_dynamics(model, q, v, a, *, gravity=None, f_ext=None):
    """Joint torques tau = M(q) a + C(q, v) v + g(q) - J^T f_ext (RNEA).

    q: (nq,) or (B, nq); v, a: (nv,) or (B, nv); gravity: (3,) in the world frame (default model.gravity);
    f_ext: (nbodies, 6) or (B, nbodies, 6), one [force, torque] per body in its body frame, torque about the
    body frame origin.  Returns tau of shape (nv,) or (B, nv).
    """
    if gravity is None and f_ext is None:  # one state: one core call, which checks q, v and a itself
        try:
            tau = _core.rnea(model.core, q, v, a)
            if tau is not None:
                return tau
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    return _run(model, q, v, a, gravity, f_ext)


def gravity_torques(model, q, *, gravity=None):
    """g(q): the torques that hold the robot still against gravity, (nv,) or (B, nv)."""
    if gravity is None:  # the fast path, as in inverse_dynamics
        try:
            tau = _core.gravity_torques(model.core, q)
            if tau is not None:
                return tau
        except checks.NOT_A_MODEL:
            pass
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    out = run(_core.gravity_batch, model, Q, checks.gravity_vector(model, gravity), out=np.empty((Q.shape[0], model.nv)))
    return out if batched else out[0]


def bias_forces(model, q, v, *, gravity=None):
    """C(q, v) v + g(q): inverse dynamics at zero acceleration, (nv,) or (B, nv)."""
    if gravity is None:  # the fast path, as in inverse_dynamics
        try:
            tau = _core.bias_forces(model.core, q, v)
            if tau is not None:
                return tau
        except checks.NOT_A_MODEL:
            pass
    checks.check_model(model)
    return _run(model, q, v, np.zeros(model.nv), gravity, None)
