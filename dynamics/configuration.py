"""Configuration update on the configuration manifold, apart from time stepping.

``integrate(model, q, v, dt)`` moves a configuration along a constant velocity ``v`` for a time ``dt``
(Pinocchio's ``integrate(model, q, v*dt)``):

* revolute, continuous, prismatic joints: ``q_j + v_j dt`` (these joints live in R);
* the free joint, q = [x, y, z, qx, qy, qz, qw], v = [v_lin, omega] in the body frame: the rigid motion of
  a constant body twist, ``(p, R) <- (p, R) Exp(xi dt)`` with the SE(3) exponential (Murray, Li & Sastry
  1994, eq. 2.36):

      R+ = R Exp(theta),                theta = omega dt
      p+ = p + R V(theta) v_lin dt,     V = 1 + (1 - cos t)/t^2 [theta] + (t - sin t)/t^3 [theta]^2

  with the quaternion updated as ``quat (x) exp(theta)`` and renormalised, so it stays unit length;
* the spherical joint, q = [qx, qy, qz, qw], v = omega in the body frame: ``quat (x) exp(omega dt)``;
* the planar joint, q = [x, y, cos theta, sin theta], v = [vx, vy, wz] in the body frame: the rigid motion of
  a constant planar twist, the SE(2) exponential (the plane's version of the formula above):

      theta+ = theta + t,               t = wz dt
      p+ = p + R(theta) V2(t) (vx, vy) dt,   V2 = [[sin t, -(1 - cos t)], [1 - cos t, sin t]] / t

``difference(model, q0, q1)`` is its inverse, the tangent d with ``integrate(model, q0, d) == q1``
(Pinocchio's ``difference``): the logarithms of SE(3), SO(3) and SE(2) of ``M0^-1 M1`` for the free, spherical
and planar joints (:func:`dynamics.joints._joint_log`), ``q1 - q0`` for the others.

The solvers (:mod:`dynamics.simulation.solvers`) do not integrate q directly.  Every step works in a *chart*
around the configuration ``q0`` at the start of the step: the step's unknown is a tangent vector
``delta`` (nv,), and ``q = _retract(q0, delta)``:

* 1-dof joints: ``q = q0 + delta`` (so the chart is exact and global);
* the free joint: ``p = p0 + delta_p`` (world-frame displacement) and ``quat = quat0 (x) exp(delta_theta)``;
* the spherical joint: the free joint's rotation part alone;
* the planar joint: ``(x, y) = (x0, y0) + delta_p`` (in the parent's plane) and ``theta = theta0 + delta_theta``
  (so its chart is exact and global, and its rate is ``(R(theta) (vx, vy), wz)``).

In that chart the kinematic equation ``q' = f(q, v)`` becomes an ODE in a vector space
(``_chart_rate``): ``delta_p' = R(q) v_lin`` and ``delta_theta' = Jr(delta_theta)^-1 omega`` with the right
Jacobian of SO(3) (Sola, Deray & Atchuthan, "A micro Lie theory for state estimation in robotics", 2018,
eq. 145).  Any Runge-Kutta method applied to it keeps its full order (this is the Munthe-Kaas idea), and
after each accepted step the chart is re-centred (``q0 <- _retract(q0, delta)``, ``delta <- 0``), so
``delta_theta`` stays small and far from the singularity of Jr^-1 at |theta| = pi.

The functions are the core's (``core/configuration.cpp``: ``integrate``, ``difference``, ``retract``,
``chart_rate``); this module checks the arguments and calls them.
"""


import numpy as np

from . import _core
from .checks import check_model, vector, zero_unit_message
from .errors import InputError
from .joints import ZERO_QUATERNION_SQ



def integrate(model, q, v, dt=1.0):
    """Configuration reached from ``q`` moving with the constant velocity ``v`` for ``dt`` seconds.

    Quaternions (free and spherical joints) and a planar joint's (cos, sin) are updated with the exponential
    map and stay unit length (module docstring).
    q: (nq,), v: (nv,), dt: finite float.  Returns a new (nq,) array.
    """
    check_model(model)
    q = _configuration(model, "q", q)
    v = vector("v", v, model.nv)
    try:
        dt = float(dt)
    except (TypeError, ValueError):
        raise InputError(f"dt: expected a finite float, got {dt!r}") from None
    if not np.isfinite(dt):
        raise InputError(f"dt: expected a finite float, got {dt!r}")
    out = np.empty(model.nq)
    _core.integrate(model.core, q, v, dt, out)
    return out


def difference(model, q0, q1):
    """The velocity that moves ``q0`` to ``q1`` in unit time: ``integrate(model, q0, difference(model, q0, q1))``
    is ``q1`` (Pinocchio's ``difference``; the logarithm of each joint's motion ``M0^-1 M1``, module docstring).

    q0, q1: (nq,).  Returns a new (nv,) array.  Quaternions and a planar joint's angle take the shorter way round
    (|angle| <= pi); a revolute or continuous joint's angle is a real number here, so its part is q1 - q0 (Pinocchio
    keeps a continuous joint's angle on the circle and takes the shorter way round there too).
    """
    check_model(model)
    q0 = _configuration(model, "q0", q0)
    q1 = _configuration(model, "q1", q1)
    out = np.empty(model.nv)
    _core.difference(model.core, q0, q1, out)
    return out


def _configuration(model, name, q):
    """One configuration (nq,), its unit blocks checked non-zero and normalised."""
    q = vector(name, q, model.nq)
    for k, n in model.unit_blocks:
        nrm = float(np.linalg.norm(q[k:k + n]))
        if nrm * nrm < ZERO_QUATERNION_SQ:
            raise InputError(zero_unit_message(model, name, int(np.flatnonzero(model.unit_blocks[:, 0] == k)[0])))
        q[k:k + n] /= nrm
    return q
