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
``delta`` (nv,), and ``q = _retract(q0, delta)``:

* 1-dof joints: ``q = q0 + delta`` (so the chart is exact and global);
* the free joint: ``p = p0 + delta_p`` (world-frame displacement) and ``quat = quat0 (x) exp(delta_theta)``.

In that chart the kinematic equation ``q' = f(q, v)`` becomes an ODE in a vector space
(``_chart_rate``): ``delta_p' = R(q) v_lin`` and ``delta_theta' = Jr(delta_theta)^-1 omega`` with the right
Jacobian of SO(3) (Sola, Deray & Atchuthan, "A micro Lie theory for state estimation in robotics", 2018,
eq. 145).  Any Runge-Kutta method applied to it keeps its full order (this is the Munthe-Kaas idea), and
after each accepted step the chart is re-centred (``q0 <- _retract(q0, delta)``, ``delta <- 0``), so
``delta_theta`` stays small and far from the singularity of Jr^-1 at |theta| = pi.

All kernels here are ``numba.njit`` and take the model's ``Tree``.  The simulation's chart functions
(:func:`retract_in`, :func:`chart_rate_in`) also take a tag (:func:`chart_tag`) whose numba type says whether
the model has a free joint: a model of 1-dof joints only compiles the plain sums, not the quaternion algebra.
"""

from typing import NamedTuple

import numpy as np
from numba.extending import overload

from ._numba import JIT_OPTIONS, inline_kernel, kernel
from .checks import check_model, vector
from .errors import InputError
from .joints import _joint_chart_rate, _joint_difference, _joint_integrate_delta, _joint_retract



@kernel
def _integrate_delta(tree, q, v, dt, delta):
    """Chart coordinates (see the module docstring) of ``_integrate_q(tree, q, v, dt)`` around q."""
    for i in range(tree.jtype.shape[0]):
        _joint_integrate_delta(tree, i, q, v, dt, delta)


@inline_kernel
def _retract(tree, q0, delta, q):
    """q = q0 (+) delta in the stepper's chart (:func:`dynamics.joints._joint_retract`)."""
    for i in range(tree.jtype.shape[0]):
        _joint_retract(tree, i, q0, delta, q)


@inline_kernel
def _chart_rate(tree, q, delta, v, out):
    """out = d(delta)/dt for velocity v, at the configuration q = _retract(q0, delta)
    (:func:`dynamics.joints._joint_chart_rate`)."""
    for i in range(tree.jtype.shape[0]):
        _joint_chart_rate(tree, i, q, delta, v, out)


class OneDofChart(NamedTuple):
    """The chart of a model of 1-dof joints only: q = q0 + delta, delta' = v (a tag: a type, no data)."""


class FreeJointChart(NamedTuple):
    """The chart of a model with a free joint (the module docstring)."""


def chart_tag(model):
    """The tag of the model's chart for :func:`retract_in` and :func:`chart_rate_in` (a free joint is the only
    joint with nq != nv)."""
    return OneDofChart() if model.nq == model.nv else FreeJointChart()


def retract_in(tag, tree, q0, delta, q):
    """:func:`_retract` for the chart named by ``tag`` (compiled code only)."""
    raise NotImplementedError


def chart_rate_in(tag, tree, q, delta, v, out):
    """:func:`_chart_rate` for the chart named by ``tag`` (compiled code only)."""
    raise NotImplementedError


def _retract_one_dof(tag, tree, q0, delta, q):
    for i in range(tree.jtype.shape[0]):
        q[tree.q_idx[i]] = q0[tree.q_idx[i]] + delta[tree.v_idx[i]]


def _retract_free(tag, tree, q0, delta, q):
    _retract(tree, q0, delta, q)


def _chart_rate_one_dof(tag, tree, q, delta, v, out):
    for i in range(tree.jtype.shape[0]):
        out[tree.v_idx[i]] = v[tree.v_idx[i]]


def _chart_rate_free(tag, tree, q, delta, v, out):
    _chart_rate(tree, q, delta, v, out)


@overload(retract_in, jit_options=JIT_OPTIONS, inline="always")
def _ov_retract_in(tag, tree, q0, delta, q):
    return _retract_one_dof if tag.instance_class is OneDofChart else _retract_free


@overload(chart_rate_in, jit_options=JIT_OPTIONS, inline="always")
def _ov_chart_rate_in(tag, tree, q, delta, v, out):
    return _chart_rate_one_dof if tag.instance_class is OneDofChart else _chart_rate_free


@kernel
def _difference(tree, q0, q1, out):
    """Tangent vector ``d`` with ``_retract(q0, d) == q1`` (the chart's inverse; used for error norms):
    q1 - q0 for 1-dof joints, (p1 - p0, log(quat0^-1 quat1)) for the free joint."""
    for i in range(tree.jtype.shape[0]):
        _joint_difference(tree, i, q0, q1, out)


@kernel
def _integrate_q(tree, q, v, dt):
    """The configuration reached from q along the constant velocity v after dt (a new array)."""
    delta = np.empty(v.shape[0])
    _integrate_delta(tree, q, v, dt, delta)
    out = np.empty(q.shape[0])
    _retract(tree, q, delta, out)
    return out


def integrate(model, q, v, dt=1.0):
    """Configuration reached from ``q`` moving with the constant velocity ``v`` for ``dt`` seconds.

    Free-flyer quaternions are updated with the exponential map and stay unit length (module docstring).
    q: (nq,), v: (nv,), dt: finite float.  Returns a new (nq,) array.
    """
    check_model(model)
    q = vector("q", q, model.nq)
    v = vector("v", v, model.nv)
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise InputError(f"dt: expected a finite float, got {dt!r}") from None
    if not np.isfinite(dt):
        raise InputError(f"dt: expected a finite float, got {dt!r}")
    return _integrate_q(model.tree, q, v, dt)
