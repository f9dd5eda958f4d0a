"""The torque sources as users describe them (:class:`PD`, :class:`Table`, ...) and as checked arrays
(:class:`Source`, from which the core's source is made).  The table of kinds and their laws is in
:mod:`dynamics.torques`."""

from typing import NamedTuple

import numpy as np

ZERO, CONSTANT, TABLE_LINEAR, TABLE_ZOH, PD_KIND, COMPUTED_TORQUE, CALLABLE, OPERATIONAL_SPACE = range(8)
KIND_NAMES = ("zero", "constant", "table_linear", "table_zoh", "pd", "computed_torque", "callable",
              "operational_space")


class Source(NamedTuple):
    """A torque source as checked arrays (:func:`~.validation.make_source`), from which the core's source is made
    (:func:`dynamics.simulation.native.core_source`; its evaluation: ``core/control/sources.cpp``)."""

    kind: int
    times: np.ndarray  # (N,) table or reference times
    table: np.ndarray  # (N, m): torques (m = nv) or reference [q, v, a] (m = 3 nv) or [p, pdot, pddot] (m = 9)
    gains: np.ndarray  # (4, nv): rows are kind-dependent (constant tau | kp, kd, v_target, tau_ff)
    qref: np.ndarray  # (nq,) PD target configuration, operational space: posture
    slot: int  # callable registry slot
    # operational space only (the other kinds carry harmless placeholders of the same types)
    frames: object  # model.frame_arrays
    frame: int  # the controlled frame, -1 for the other kinds
    rows: np.ndarray  # (r,) int64: task rows of [linear; angular]
    task_gains: np.ndarray  # (2, 6): Kp, Kd per task row
    orientation: np.ndarray  # (N, 12): reference orientation R_k (9) and psi_k = log(R_k+1 R_k^T) (3)
    damping: float  # added to the diagonal of J M^-1 J^T
    ws: object  # None (kept for the field order)



# ---------------------------------------------------------------------------------------------------
# user-facing descriptions
class Table:
    """Tabulated torques: times (N,) strictly increasing, tau (N, nv); hold "linear" or "zoh"."""

    def __init__(self, t, tau, hold="linear"):
        self.t, self.tau, self.hold = t, tau, hold


class PD:
    """PD control to a target posture: tau = kp (q_target - q) + kd (v_target - v) + tau_ff.

    kp, kd: scalars or (nv,) arrays (>= 0); v_target, tau_ff: (nv,) arrays, default zero.
    """

    def __init__(self, q_target, kp, kd, v_target=None, tau_ff=None):
        self.q_target, self.kp, self.kd, self.v_target, self.tau_ff = q_target, kp, kd, v_target, tau_ff


class ComputedTorque:
    """Computed-torque tracking of a reference (t (N,), q (N, nq), v (N, nv), a (N, nv)); fixed base only.

    kp, kd: scalars or (nv,) arrays (>= 0).  The reference is interpolated by quintic Hermite polynomials.
    """

    def __init__(self, t, q, v, a, kp, kd):
        self.t, self.q, self.v, self.a, self.kp, self.kd = t, q, v, a, kp, kd


class OperationalSpace:
    """Operational-space control of ``frame`` along ``reference`` (:mod:`dynamics.control.operational_space`).

    reference: ``(t, position)`` or ``(t, position, orientation)``, or a :class:`TaskReference` (which can also
    give the velocities and accelerations): t (N,) strictly increasing, position (N, 3) of the frame origin in
    the world, orientation (N, 3, 3) or one (3, 3) rotation of the frame's axes in the world.
    rows: the task rows of [x, y, z, wx, wy, wz] (world axes), default the 3 position rows, or all 6 with an
    orientation.  kp, kd: >= 0, scalars or one per task row (task-space acceleration gains, 1/s^2 and 1/s).
    posture (nq,): the null-space posture, pulled by the joint torques posture_kp (posture - q) - posture_kd v
    projected into the dynamically consistent null space (posture_kp in N m/rad, scalar or (nv,));
    posture_kd defaults to 2 sqrt(posture_kp M_ii(posture)) (each joint critically damped on its own inertia).
    Without a posture (posture_kp must then be 0) posture_kd (default 0) damps the joints toward rest alone.
    Before the first and after the last sample the reference holds its end position at rest.
    damping >= 0: added to the diagonal of J M^-1 J^T (robust near singularities, at the cost of exact
    tracking).  Fixed base only.
    """

    def __init__(self, frame, reference, kp, kd, posture=None, posture_kp=0.0, posture_kd=None, rows=None,
                 damping=0.0):
        self.frame, self.reference, self.kp, self.kd = frame, reference, kp, kd
        self.posture, self.posture_kp, self.posture_kd = posture, posture_kp, posture_kd
        self.rows, self.damping = rows, damping


class TaskReference:
    """A task-space reference: t (N,), position (N, 3), optional velocity and acceleration (N, 3) (central
    finite differences of the positions when absent) and orientation (N, 3, 3) or (3, 3).  Positions are
    interpolated by quintic Hermite polynomials through (position, velocity, acceleration); the orientation
    along the geodesic between samples at constant angular velocity."""

    def __init__(self, t, position, velocity=None, acceleration=None, orientation=None):
        self.t, self.position, self.velocity, self.acceleration = t, position, velocity, acceleration
        self.orientation = orientation


class Target(OperationalSpace):
    """Operational-space regulation of ``frame`` to a fixed position (3,) and, if given, orientation (3, 3):
    the constant-reference form of :class:`OperationalSpace` (same keyword arguments)."""

    def __init__(self, frame, position, orientation=None, *, kp, kd, **kwargs):
        super().__init__(frame, None, kp, kd, **kwargs)
        self.position, self.orientation = position, orientation
