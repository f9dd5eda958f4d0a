"""Joint torque sources for :func:`dynamics.simulate`, and the passive joint torques of the model.

A torque source turns (t, q, v) into the applied joint torques tau (nv,).  Every source is checked into one
record of arrays (``Source``) and evaluated by the C++ core inside the integration loop (``core/control/``); a
Python callable is called back from there.

=====================  ========================================================================================
``torque=`` argument   tau(t, q, v)
=====================  ========================================================================================
``None``               0
array (nv,)            the constant vector
``Table(t, tau)``      piecewise linear in t through the rows of tau (N, nv); ``hold="zoh"``: tau[k] on
                       [t_k, t_k+1).  Before t_0 / after t_N-1 the first / last row.
``PD(q_target, kp,     kp (q_target - q) + kd (v_target - v) + tau_ff; the position error is the tangent
kd)``                  vector from q to q_target (:func:`dynamics.difference`), so it is also
                       defined for a free-flyer (whose gains are zero by default unless given per dof).
``ComputedTorque(t,    M(q) a* + h(q, v) - tau_passive(q, v) with a* = a_ref + kd (v_ref - v) + kp (q_ref - q)
q, v, a, kp, kd)``     (inverse dynamics, the RNEA), so the closed loop is e'' + kd e' + kp e = 0 exactly for the
                       model.  The reference is a table of samples (t_k, q_k, v_k, a_k) interpolated by quintic
                       Hermite polynomials, which are C2 and consistent (v_ref = q_ref', a_ref = v_ref').
``OperationalSpace(    operational-space control of a frame's position (and orientation) along a reference
frame, reference,      trajectory: tau = J^T (Lambda xdd* + mu + p) + N tau_0 with a null-space posture task
kp, kd)``, ``Target``  (``core/control/operational_space.hpp``); ``Target`` holds a fixed pose.
callable f(t, q, v)    called back from the core's loop with the GIL taken (one Python call per right-hand-side
                       evaluation; everything else stays in C++).
=====================  ========================================================================================

Passive joint torques (``core/control/passive.cpp``), always added by the simulator:

* viscous damping ``-d v`` (URDF ``<dynamics damping>``);
* Coulomb friction ``-F tanh(v / eps)`` (URDF ``<dynamics friction>``), regularised with the velocity scale
  ``eps`` (``friction_eps``, default 1e-3 rad/s or m/s): exact Coulomb for |v| >> eps, a stiff viscous law of
  slope F/eps near rest (so tiny eps makes the problem stiff);
* with ``limits="spring"``, a Hunt-Crossley spring-damper at the URDF position limits, penetration
  x = lower - q (or q - upper) > 0:  ``tau = +-max(0, k x + b x x')`` (stiffness k, damping b*x that vanishes
  at contact, so the force is continuous).

The code lives in :mod:`dynamics.control`, one module per concern: :mod:`~dynamics.control.sources` (the
classes above and the checked :class:`Source`), :mod:`~dynamics.control.validation` (:func:`make_source`, the
input checks), :mod:`~dynamics.control.passive` and :mod:`~dynamics.control.registry` (Python callables); the
core evaluates every kind (``core/control/``: the sources, their references' interpolation, the
operational-space controller).  This module is their public face: ``dynamics.torques.PD(...)``.
"""

from .control.passive import Passive
from .control.registry import register_callable, release_callable
from .control.sources import (CALLABLE, COMPUTED_TORQUE, CONSTANT, KIND_NAMES, OPERATIONAL_SPACE, PD, PD_KIND,
                              TABLE_LINEAR, TABLE_ZOH, ZERO, ComputedTorque, OperationalSpace, Source, Table,
                              TaskReference, Target)
from .control.validation import make_source

__all__ = ["Table", "PD", "ComputedTorque", "OperationalSpace", "TaskReference", "Target", "Passive", "Source",
           "make_source", "register_callable", "release_callable", "KIND_NAMES", "ZERO", "CONSTANT", "TABLE_LINEAR",
           "TABLE_ZOH", "PD_KIND", "COMPUTED_TORQUE", "CALLABLE", "OPERATIONAL_SPACE"]
