"""Configuration update on the configuration manifold, apart from time stepping.

``integrate(model, q, v, dt)`` moves a configuration along a constant velocity ``v`` for a time ``dt``
(Pinocchio's ``integrate(model, q, v*dt)``):

* revolute, continuous, prismatic joints: ``q_j + v_j dt`` (these joints live in R);
* the free joint, q = [x, y, z, qx, qy, qz, qw], v = [v_lin, omega] in the body frame: the rigid motion of
  a constant body twist, ``(p, R) <- (p, R) Exp(xi dt)`` with the SE(3) exponential (Murray, Li & Sastry
  1994, eq. 2.36):

      R+ = R Exp(theta),                theta = omega dt
      p+ = p + R V(theta) v_lin dt,     V = 1 + (1 - cos t)/t^2 [theta] + (t - sin t)/t^3 [theta]^2

  with the quaternion updated as ``quat (x) exp(theta)`` and renormalised, so it stays unit length.

The steppers (:mod:`dynamics.integrators`) do not integrate q directly.  Every step works in a *chart*
around the configuration ``q0`` at the start of the step: the step's unknown is a tangent vector
``delta`` (nv,), and ``q = retract(q0, delta)``:

* 1-dof joints: ``q = q0 + delta`` (so the chart is exact and global);
* the free joint: ``p = p0 + delta_p`` (world-frame displacement) and ``quat = quat0 (x) exp(delta_theta)``.

In that chart the kinematic equation ``q' = f(q, v)`` becomes an ODE in a vector space
(``chart_rate``): ``delta_p' = R(q) v_lin`` and ``delta_theta' = Jr(delta_theta)^-1 omega`` with the right
Jacobian of SO(3) (Sola, Deray & Atchuthan, "A micro Lie theory for state estimation in robotics", 2018,
eq. 145).  Any Runge-Kutta method applied to it keeps its full order (this is the Munthe-Kaas idea), and
after each accepted step the chart is re-centred (``q0 <- retract(q0, delta)``, ``delta <- 0``), so
``delta_theta`` stays small and far from the singularity of Jr^-1 at |theta| = pi.

All kernels here are ``numba.njit`` and take the model's ``Tree``.
"""

import numpy as np
from numba import njit

from .errors import InputError
from .joints import JOINT_FREE
from .spatial import exp_quat, quat_multiply, quat_to_rot

_JIT = dict(cache=True, nogil=True)


@njit(**_JIT)
def _rotvec_terms(th0, th1, th2):
    """(phi^2, a, b) with V = 1 + a [th] + b [th]^2 (the SE(3) left Jacobian of SO(3)), series near 0."""
    phi2 = th0 * th0 + th1 * th1 + th2 * th2
    if phi2 < 1e-8:
        a = 0.5 - phi2 / 24.0
        b = 1.0 / 6.0 - phi2 / 120.0
    else:
        phi = np.sqrt(phi2)
        a = (1.0 - np.cos(phi)) / phi2
        b = (phi - np.sin(phi)) / (phi2 * phi)
    return phi2, a, b


@njit(**_JIT)
def _skew_apply(a, b, th, x, out):
    """out = (1 + a [th] + b [th]^2) x."""
    c0 = th[1] * x[2] - th[2] * x[1]
    c1 = th[2] * x[0] - th[0] * x[2]
    c2 = th[0] * x[1] - th[1] * x[0]
    d0 = th[1] * c2 - th[2] * c1
    d1 = th[2] * c0 - th[0] * c2
    d2 = th[0] * c1 - th[1] * c0
    out[0] = x[0] + a * c0 + b * d0
    out[1] = x[1] + a * c1 + b * d1
    out[2] = x[2] + a * c2 + b * d2


@njit(**_JIT)
def integrate_delta(tree, q, v, dt, delta):
    """Chart coordinates (see the module docstring) of ``integrate_q(tree, q, v, dt)`` around q."""
    R = np.empty((3, 3))
    th = np.empty(3)
    tmp = np.empty(3)
    for i in range(tree.jtype.shape[0]):
        k = tree.v_idx[i]
        if tree.jtype[i] == JOINT_FREE:
            kq = tree.q_idx[i]
            for r in range(3):
                th[r] = v[k + 3 + r] * dt
                tmp[r] = v[k + r] * dt
            phi2, a, b = _rotvec_terms(th[0], th[1], th[2])
            _skew_apply(a, b, th, tmp, tmp)  # V(theta) v_lin dt, in the body frame
            quat_to_rot(q[kq + 3], q[kq + 4], q[kq + 5], q[kq + 6], R)
            for r in range(3):
                delta[k + r] = R[r, 0] * tmp[0] + R[r, 1] * tmp[1] + R[r, 2] * tmp[2]
                delta[k + 3 + r] = th[r]
        else:
            delta[k] = v[k] * dt


@njit(**_JIT)
def retract(tree, q0, delta, q):
    """q = q0 (+) delta in the stepper's chart: q0 + delta for 1-dof joints; p0 + delta_p and
    quat0 (x) exp(delta_theta), renormalised, for the free joint."""
    dq = np.empty(4)
    qn = np.empty(4)
    for i in range(tree.jtype.shape[0]):
        k = tree.v_idx[i]
        kq = tree.q_idx[i]
        if tree.jtype[i] == JOINT_FREE:
            for r in range(3):
                q[kq + r] = q0[kq + r] + delta[k + r]
            exp_quat(delta[k + 3:k + 6], dq)
            quat_multiply(q0[kq + 3:kq + 7], dq, qn)
            nrm = np.sqrt(qn[0] ** 2 + qn[1] ** 2 + qn[2] ** 2 + qn[3] ** 2)
            for r in range(4):
                q[kq + 3 + r] = qn[r] / nrm
        else:
            q[kq] = q0[kq] + delta[k]


@njit(**_JIT)
def chart_rate(tree, q, delta, v, out):
    """out = d(delta)/dt for velocity v, at the configuration q = retract(q0, delta).

    1-dof joints: v.  Free joint: (R(q) v_lin, Jr(delta_theta)^-1 omega), with
    Jr^-1 = 1 + [th]/2 + (1/phi^2 - (1 + cos phi)/(2 phi sin phi)) [th]^2.
    """
    R = np.empty((3, 3))
    for i in range(tree.jtype.shape[0]):
        k = tree.v_idx[i]
        if tree.jtype[i] == JOINT_FREE:
            kq = tree.q_idx[i]
            quat_to_rot(q[kq + 3], q[kq + 4], q[kq + 5], q[kq + 6], R)
            for r in range(3):
                out[k + r] = R[r, 0] * v[k] + R[r, 1] * v[k + 1] + R[r, 2] * v[k + 2]
            th = delta[k + 3:k + 6]
            phi2 = th[0] * th[0] + th[1] * th[1] + th[2] * th[2]
            if phi2 < 1e-8:
                c = 1.0 / 12.0 + phi2 / 720.0
            else:
                phi = np.sqrt(phi2)
                c = 1.0 / phi2 - (1.0 + np.cos(phi)) / (2.0 * phi * np.sin(phi))
            _skew_apply(0.5, c, th, v[k + 3:k + 6], out[k + 3:k + 6])
        else:
            out[k] = v[k]


@njit(**_JIT)
def difference(tree, q0, q1, out):
    """Tangent vector ``d`` with ``retract(q0, d) == q1`` (the chart's inverse; used for error norms):
    q1 - q0 for 1-dof joints, (p1 - p0, log(quat0^-1 quat1)) for the free joint."""
    qi = np.empty(4)
    qr = np.empty(4)
    for i in range(tree.jtype.shape[0]):
        k = tree.v_idx[i]
        kq = tree.q_idx[i]
        if tree.jtype[i] == JOINT_FREE:
            for r in range(3):
                out[k + r] = q1[kq + r] - q0[kq + r]
                qi[r] = -q0[kq + 3 + r]
            qi[3] = q0[kq + 6]
            quat_multiply(qi, q1[kq + 3:kq + 7], qr)
            if qr[3] < 0.0:  # the shorter way round
                for r in range(4):
                    qr[r] = -qr[r]
            s = np.sqrt(qr[0] ** 2 + qr[1] ** 2 + qr[2] ** 2)
            ang = 2.0 * np.arctan2(s, qr[3])
            f = 2.0 if s < 1e-12 else ang / s
            for r in range(3):
                out[k + 3 + r] = f * qr[r]
        else:
            out[k] = q1[kq] - q0[kq]


@njit(**_JIT)
def integrate_q(tree, q, v, dt):
    """The configuration reached from q along the constant velocity v after dt (a new array)."""
    delta = np.empty(v.shape[0])
    integrate_delta(tree, q, v, dt, delta)
    out = np.empty(q.shape[0])
    retract(tree, q, delta, out)
    return out


def _vector(name, x, n):
    try:
        a = np.ascontiguousarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a float array of shape ({n},), got {type(x).__name__}") from None
    if a.shape != (n,):
        raise InputError(f"{name}: expected shape ({n},), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name}: contains non-finite values")
    return a


def integrate(model, q, v, dt=1.0):
    """Configuration reached from ``q`` moving with the constant velocity ``v`` for ``dt`` seconds.

    Free-flyer quaternions are updated with the exponential map and stay unit length (module docstring).
    q: (nq,), v: (nv,), dt: finite float.  Returns a new (nq,) array.
    """
    q = _vector("q", q, model.nq)
    v = _vector("v", v, model.nv)
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise InputError(f"dt: expected a finite float, got {dt!r}") from None
    if not np.isfinite(dt):
        raise InputError(f"dt: expected a finite float, got {dt!r}")
    return integrate_q(model.tree, q, v, dt)
