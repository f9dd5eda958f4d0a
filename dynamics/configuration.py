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

The solvers (:mod:`dynamics.simulation.solvers`) do not integrate q directly.  Every step works in a *chart*
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

All kernels here are ``numba.njit`` and take the model's ``Tree``.  The simulation's chart functions
(:func:`retract_in`, :func:`chart_rate_in`) also take a tag (:func:`chart_tag`) whose numba type says whether
the model has a free joint: a model of 1-dof joints only compiles the plain sums, not the quaternion algebra.
"""

from typing import NamedTuple

import numpy as np
from numba.extending import overload

from ._numba import JIT_OPTIONS, inline_kernel, kernel
from .checks import vector
from .errors import InputError
from .joints import JOINT_FREE



@inline_kernel
def _qmul(ax, ay, az, aw, bx, by, bz, bw):
    """Hamilton product a * b of quaternions (x, y, z, w)."""
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


@inline_kernel
def _qexp(w0, w1, w2):
    """Unit quaternion of the rotation vector w (exp map), accurate near zero."""
    th2 = w0 * w0 + w1 * w1 + w2 * w2
    if th2 < 1e-12:
        s = 0.5 - th2 / 48.0  # sin(th/2)/th by its Taylor series
        c = 1.0 - th2 / 8.0
    else:
        th = np.sqrt(th2)
        s = np.sin(0.5 * th) / th
        c = np.cos(0.5 * th)
    return s * w0, s * w1, s * w2, c


@inline_kernel
def _qrot(x, y, z, w, a0, a1, a2):
    """R(quat) a for a unit quaternion (x, y, z, w)."""
    # a + 2 w (u x a) + 2 u x (u x a), u = (x, y, z)
    c0 = y * a2 - z * a1
    c1 = z * a0 - x * a2
    c2 = x * a1 - y * a0
    return (a0 + 2.0 * (w * c0 + y * c2 - z * c1),
            a1 + 2.0 * (w * c1 + z * c0 - x * c2),
            a2 + 2.0 * (w * c2 + x * c1 - y * c0))


@inline_kernel
def _skew_poly(a, b, t0, t1, t2, x0, x1, x2):
    """(1 + a [t] + b [t]^2) x."""
    c0 = t1 * x2 - t2 * x1
    c1 = t2 * x0 - t0 * x2
    c2 = t0 * x1 - t1 * x0
    d0 = t1 * c2 - t2 * c1
    d1 = t2 * c0 - t0 * c2
    d2 = t0 * c1 - t1 * c0
    return x0 + a * c0 + b * d0, x1 + a * c1 + b * d1, x2 + a * c2 + b * d2


@kernel
def integrate_delta(tree, q, v, dt, delta):
    """Chart coordinates (see the module docstring) of ``integrate_q(tree, q, v, dt)`` around q."""
    for i in range(tree.jtype.shape[0]):
        k = tree.v_idx[i]
        if tree.jtype[i] == JOINT_FREE:
            kq = tree.q_idx[i]
            t0, t1, t2 = v[k + 3] * dt, v[k + 4] * dt, v[k + 5] * dt
            phi2 = t0 * t0 + t1 * t1 + t2 * t2
            if phi2 < 1e-8:  # V = 1 + a [t] + b [t]^2 by its series
                a = 0.5 - phi2 / 24.0
                b = 1.0 / 6.0 - phi2 / 120.0
            else:
                phi = np.sqrt(phi2)
                a = (1.0 - np.cos(phi)) / phi2
                b = (phi - np.sin(phi)) / (phi2 * phi)
            x0, x1, x2 = _skew_poly(a, b, t0, t1, t2, v[k] * dt, v[k + 1] * dt, v[k + 2] * dt)
            nrm = np.sqrt(q[kq + 3] ** 2 + q[kq + 4] ** 2 + q[kq + 5] ** 2 + q[kq + 6] ** 2)
            p0, p1, p2 = _qrot(q[kq + 3] / nrm, q[kq + 4] / nrm, q[kq + 5] / nrm, q[kq + 6] / nrm, x0, x1, x2)
            delta[k], delta[k + 1], delta[k + 2] = p0, p1, p2
            delta[k + 3], delta[k + 4], delta[k + 5] = t0, t1, t2
        else:
            delta[k] = v[k] * dt


@inline_kernel
def retract(tree, q0, delta, q):
    """q = q0 (+) delta in the stepper's chart: q0 + delta for 1-dof joints; p0 + delta_p and
    quat0 (x) exp(delta_theta), renormalised, for the free joint."""
    for i in range(tree.jtype.shape[0]):
        k = tree.v_idx[i]
        kq = tree.q_idx[i]
        if tree.jtype[i] == JOINT_FREE:
            for r in range(3):
                q[kq + r] = q0[kq + r] + delta[k + r]
            dx, dy, dz, dw = _qexp(delta[k + 3], delta[k + 4], delta[k + 5])
            x, y, z, w = _qmul(q0[kq + 3], q0[kq + 4], q0[kq + 5], q0[kq + 6], dx, dy, dz, dw)
            nrm = np.sqrt(x * x + y * y + z * z + w * w)
            q[kq + 3], q[kq + 4], q[kq + 5], q[kq + 6] = x / nrm, y / nrm, z / nrm, w / nrm
        else:
            q[kq] = q0[kq] + delta[k]


@inline_kernel
def chart_rate(tree, q, delta, v, out):
    """out = d(delta)/dt for velocity v, at the configuration q = retract(q0, delta).

    1-dof joints: v.  Free joint: (R(q) v_lin, Jr(delta_theta)^-1 omega), with
    Jr^-1 = 1 + [th]/2 + (1/phi^2 - (1 + cos phi)/(2 phi sin phi)) [th]^2.
    """
    for i in range(tree.jtype.shape[0]):
        k = tree.v_idx[i]
        if tree.jtype[i] == JOINT_FREE:
            kq = tree.q_idx[i]
            out[k], out[k + 1], out[k + 2] = _qrot(q[kq + 3], q[kq + 4], q[kq + 5], q[kq + 6],
                                                   v[k], v[k + 1], v[k + 2])
            t0, t1, t2 = delta[k + 3], delta[k + 4], delta[k + 5]
            phi2 = t0 * t0 + t1 * t1 + t2 * t2
            if phi2 < 1e-8:
                c = 1.0 / 12.0 + phi2 / 720.0
            else:
                phi = np.sqrt(phi2)
                c = 1.0 / phi2 - (1.0 + np.cos(phi)) / (2.0 * phi * np.sin(phi))
            out[k + 3], out[k + 4], out[k + 5] = _skew_poly(0.5, c, t0, t1, t2, v[k + 3], v[k + 4], v[k + 5])
        else:
            out[k] = v[k]


class OneDofChart(NamedTuple):
    """The chart of a model of 1-dof joints only: q = q0 + delta, delta' = v (a tag: a type, no data)."""


class FreeJointChart(NamedTuple):
    """The chart of a model with a free joint (the module docstring)."""


def chart_tag(model):
    """The tag of the model's chart for :func:`retract_in` and :func:`chart_rate_in` (a free joint is the only
    joint with nq != nv)."""
    return OneDofChart() if model.nq == model.nv else FreeJointChart()


def retract_in(tag, tree, q0, delta, q):
    """:func:`retract` for the chart named by ``tag`` (compiled code only)."""
    raise NotImplementedError


def chart_rate_in(tag, tree, q, delta, v, out):
    """:func:`chart_rate` for the chart named by ``tag`` (compiled code only)."""
    raise NotImplementedError


def _retract_one_dof(tag, tree, q0, delta, q):
    for i in range(tree.jtype.shape[0]):
        q[tree.q_idx[i]] = q0[tree.q_idx[i]] + delta[tree.v_idx[i]]


def _retract_free(tag, tree, q0, delta, q):
    retract(tree, q0, delta, q)


def _chart_rate_one_dof(tag, tree, q, delta, v, out):
    for i in range(tree.jtype.shape[0]):
        out[tree.v_idx[i]] = v[tree.v_idx[i]]


def _chart_rate_free(tag, tree, q, delta, v, out):
    chart_rate(tree, q, delta, v, out)


@overload(retract_in, jit_options=JIT_OPTIONS, inline="always")
def _ov_retract_in(tag, tree, q0, delta, q):
    return _retract_one_dof if tag.instance_class is OneDofChart else _retract_free


@overload(chart_rate_in, jit_options=JIT_OPTIONS, inline="always")
def _ov_chart_rate_in(tag, tree, q, delta, v, out):
    return _chart_rate_one_dof if tag.instance_class is OneDofChart else _chart_rate_free


@kernel
def difference(tree, q0, q1, out):
    """Tangent vector ``d`` with ``retract(q0, d) == q1`` (the chart's inverse; used for error norms):
    q1 - q0 for 1-dof joints, (p1 - p0, log(quat0^-1 quat1)) for the free joint."""
    for i in range(tree.jtype.shape[0]):
        k = tree.v_idx[i]
        kq = tree.q_idx[i]
        if tree.jtype[i] == JOINT_FREE:
            for r in range(3):
                out[k + r] = q1[kq + r] - q0[kq + r]
            x, y, z, w = _qmul(-q0[kq + 3], -q0[kq + 4], -q0[kq + 5], q0[kq + 6],
                               q1[kq + 3], q1[kq + 4], q1[kq + 5], q1[kq + 6])
            if w < 0.0:  # the shorter way round
                x, y, z, w = -x, -y, -z, -w
            s = np.sqrt(x * x + y * y + z * z)
            ang = 2.0 * np.arctan2(s, w)
            f = 2.0 / w if s < 1e-12 else ang / s
            out[k + 3], out[k + 4], out[k + 5] = f * x, f * y, f * z
        else:
            out[k] = q1[kq] - q0[kq]


@kernel
def integrate_q(tree, q, v, dt):
    """The configuration reached from q along the constant velocity v after dt (a new array)."""
    delta = np.empty(v.shape[0])
    integrate_delta(tree, q, v, dt, delta)
    out = np.empty(q.shape[0])
    retract(tree, q, delta, out)
    return out


def integrate(model, q, v, dt=1.0):
    """Configuration reached from ``q`` moving with the constant velocity ``v`` for ``dt`` seconds.

    Free-flyer quaternions are updated with the exponential map and stay unit length (module docstring).
    q: (nq,), v: (nv,), dt: finite float.  Returns a new (nq,) array.
    """
    q = vector("q", q, model.nq)
    v = vector("v", v, model.nv)
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise InputError(f"dt: expected a finite float, got {dt!r}") from None
    if not np.isfinite(dt):
        raise InputError(f"dt: expected a finite float, got {dt!r}")
    return integrate_q(model.tree, q, v, dt)
