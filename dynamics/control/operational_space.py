"""Operational-space control of a frame (Khatib 1987, "A unified approach for motion and force control of robot
manipulators: the operational space formulation"; Featherstone 2008, sec. 9.3), the kernel behind
:class:`dynamics.torques.OperationalSpace` and :class:`dynamics.torques.Target`.

The task x is the frame's position (and orientation) in the world, with velocity J v, J the frame's Jacobian at
"local_world_aligned" (:mod:`dynamics.jacobians`) restricted to the task rows (of [linear; angular]), and
acceleration xdd = J vd + Jdot v (Jdot v: :func:`dynamics.frame_bias_acceleration`).  With M vd + b = tau
(b = C v + g minus the passive torques the simulator adds), the task-space dynamics are

    F = Lambda xdd + mu + p,     Lambda = (J M^-1 J^T)^-1,     mu + p = Lambda (J M^-1 b - Jdot v),

and the controller commands the task acceleration xdd* = xdd_d + Kd edot + Kp e, plus a posture task in the
dynamically consistent null space (N = 1 - J^T Jbar^T, Jbar = M^-1 J^T Lambda, so J M^-1 N = 0):

    tau = J^T (Lambda xdd* + mu + p) + N tau_0,     tau_0 = b + tau_p,     tau_p = Kp0 (q_0 - q) - Kd0 v.

The posture is a joint stiffness (N m/rad): at rest the posture error that the task forces on the arm is the
stiffness-weighted least-squares one (N tau_p = 0: Kp0 e in the range of J^T), so every joint shares the task's
motion by its stiffness, not by its inertia (an acceleration-level posture M a_0 would let the light wrist take
it all).  Expanding N (N b + J^T Lambda J M^-1 b = b), the same torque is

    tau = ID(q, v, 0) + tau_p + J^T Lambda (xdd* - Jdot v - J M^-1 tau_p)                           (*)

(ID the RNEA, :mod:`dynamics.rnea`), which is what the kernel evaluates: one RNEA, one M^-1
(:mod:`dynamics.minverse`), one Jacobian, one Jdot v, and an r x r solve (r <= 6 task rows).  The closed
loop is xdd = xdd* exactly for the model, i.e. e'' + Kd e' + Kp e = 0 per task row, and N tau_p drives the
directions the task leaves free.

Errors: e = p_d - p for the position; for the orientation e = log(R_d R^T) (world axes,
:func:`dynamics.spatial._rotation_log`) and edot = w_d - w, exact to first order in the error.  When J M^-1 J^T
is singular (the frame at a singularity of its task rows: a condition number above
:data:`dynamics.task_space.MAX_CONDITION`, as for :func:`dynamics.operational_space_inertia`) the torque is NaN
and the simulation stops with a non-finite status; ``damping`` d > 0 uses (J M^-1 J^T + d 1)^-1 instead.
"""

import numpy as np

from .._numba import helper, kernel
from ..configuration import _difference
from ..jacobians import _jacobian_into
from ..kinematics import BIAS_ACCELERATION, LOCAL_WORLD_ALIGNED, _motion_batch
from ..minverse import _minverse_into
from ..minverse import _workspace as minverse_workspace
from ..rnea import _rnea_into
from ..spatial import matmul, _rotation_about_axis, _rotation_log, _spd_inverse, transpose
from ..task_space import MAX_CONDITION
from .interpolation import reference_at


@kernel
def orientation_at(times, otable, t):
    """The reference orientation R_d (9-tuple) and its angular velocity w_d (world) at t.  otable[k] = [R_k (9),
    psi_k (3)], psi_k = log(R_k+1 R_k^T): between samples R_d = Exp((t - t_k) psi_k / h) R_k (the geodesic),
    w_d = psi_k / h; clamped to the first / last sample (w_d = 0) outside [t_0, t_N-1]."""
    N = times.shape[0]
    if N == 1 or t <= times[0] or t >= times[N - 1]:
        k = 0 if (N == 1 or t <= times[0]) else N - 1
        R = otable[k]
        return (R[0], R[1], R[2], R[3], R[4], R[5], R[6], R[7], R[8]), (0.0, 0.0, 0.0)
    k = np.searchsorted(times, t, side="right") - 1
    if k > N - 2:
        k = N - 2
    h = times[k + 1] - times[k]
    o = otable[k]
    psi = (o[9], o[10], o[11])
    w = (psi[0] / h, psi[1] / h, psi[2] / h)
    angle = np.sqrt(psi[0] * psi[0] + psi[1] * psi[1] + psi[2] * psi[2])
    Rk = (o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7], o[8])
    if angle == 0.0:
        return Rk, w
    s = (t - times[k]) / h
    E = _rotation_about_axis((psi[0] / angle, psi[1] / angle, psi[2] / angle), s * angle)
    return matmul(E, Rk), w


@helper
def _workspace(nb, nv, nq):
    """Scratch of :func:`operational_space_into`, one per simulation (its Source): J is zero off the frame's
    support, which is all _jacobian_into leaves untouched, and ``zero`` is never written."""
    return (np.empty(nb, np.int64), np.empty((nb, 3, 3)), np.empty((nb, 3)), np.zeros((6, nv)),  # path, poses, J
            np.empty((1, nq)), np.empty((1, nv)), np.empty((1, 6)),  # q, v, Jdot v as batches of one
            np.empty((nv, nv)), minverse_workspace(nb, nv), np.empty(nv), np.zeros(nv),  # M^-1, tau_p, zero
            np.empty((6, nv)), np.empty(6), np.empty((6, 6)), np.empty((1, 6, 6)), np.empty((6, 6)))  # JM, y, Lambda


@kernel
def task_reference_at(src, t, x_ref):
    """x_ref (3, 3) = [p_d; pdot_d; pddot_d] at t, interpolated in the reference's table; outside its times the
    end position is held at rest."""
    reference_at(src.times, src.table, 3, t, x_ref[0], x_ref[1], x_ref[2])
    if t < src.times[0] or t > src.times[-1]:
        x_ref[1:] = 0.0


@kernel
def operational_space_into(src, tree, gravity, f_ext, t, q, v, x_ref, tau_passive, ws_rnea, tau):
    """tau by (*) of the module docstring for the task of ``src`` (a :class:`dynamics.torques.Source`):
    frame ``src.frame`` of ``src.frames``, rows ``src.rows``, gains ``src.task_gains`` [Kp; Kd] (2, 6) and
    posture gains ``src.gains`` [Kp0; Kd0] toward ``src.qref``.  x_ref (3, 3) = [p_d; pdot_d; pddot_d] at t
    (:func:`task_reference_at`).  Returns the frame's world pose (R, p); leaves J, M^-1, tau_p, J M^-1, y and
    Lambda in ``src.ws`` (:mod:`.operational_space_derivatives` reads them)."""
    frames, f, rows, kt = src.frames, src.frame, src.rows, src.task_gains
    path, oR, op, J, Q1, V1, jdv, Minv, ws_minv, tp, zero, JM, y, A, Lam, scratch = src.ws
    nv, r = v.shape[0], rows.shape[0]
    R, p = _jacobian_into(tree, frames, q, f, LOCAL_WORLD_ALIGNED, (0.0, 0.0, 0.0), path, oR, op, J)
    Q1[0], V1[0] = q, v
    _motion_batch(tree, Q1, V1, V1, frames, f, LOCAL_WORLD_ALIGNED, BIAS_ACCELERATION, True, jdv)
    if _minverse_into(tree, q, ws_minv, Minv) >= 0:
        tau[:] = np.nan
        return R, p
    # the posture torque tau_p = Kp0 (q_0 - q) - Kd0 v, and b = ID(q, v, 0) - tau_passive into tau
    _difference(tree, q, src.qref, tp)
    for i in range(nv):
        tp[i] = src.gains[0, i] * tp[i] - src.gains[1, i] * v[i]
    _rnea_into(tree, q, v, zero, gravity, f_ext, ws_rnea, tau)
    for i in range(nv):
        tau[i] += tp[i] - tau_passive[i]
    # J M^-1 (task rows)
    for a in range(r):
        for c in range(nv):
            x = 0.0
            for s in range(nv):
                x += J[rows[a], s] * Minv[s, c]
            JM[a, c] = x
    # task errors (6 rows, world axes) and y = xdd* - Jdot v - J M^-1 tau_p
    Rd, wd = orientation_at(src.times, src.orientation, t)
    eo = _rotation_log(matmul(Rd, transpose(R)))
    e = (x_ref[0, 0] - p[0], x_ref[0, 1] - p[1], x_ref[0, 2] - p[2], eo[0], eo[1], eo[2])
    xd_d = (x_ref[1, 0], x_ref[1, 1], x_ref[1, 2], wd[0], wd[1], wd[2])
    xdd_d = (x_ref[2, 0], x_ref[2, 1], x_ref[2, 2], 0.0, 0.0, 0.0)
    for a in range(r):
        k = rows[a]
        xd = 0.0
        JMtp = 0.0
        for c in range(nv):
            xd += J[k, c] * v[c]
            JMtp += JM[a, c] * tp[c]
        y[a] = xdd_d[k] + kt[1, k] * (xd_d[k] - xd) + kt[0, k] * e[k] - jdv[0, k] - JMtp
    # Lambda = (J M^-1 J^T + d 1)^-1, then tau += J^T Lambda y
    for a in range(r):
        for b in range(r):
            x = src.damping if a == b else 0.0
            for s in range(nv):
                x += JM[a, s] * J[rows[b], s]
            A[a, b] = x
    ok = _spd_inverse(A, r, Lam, 0, scratch)
    big_A, big_Lam = 0.0, 0.0
    for a in range(r):  # max diag(A) max diag(A^-1) <= cond(A) <= r^2 times it (A symmetric positive definite)
        big_A, big_Lam = max(big_A, A[a, a]), max(big_Lam, Lam[0, a, a])
    if not ok or not big_A * big_Lam <= MAX_CONDITION:
        tau[:] = np.nan
        return R, p
    for a in range(r):
        F = 0.0
        for b in range(r):
            F += Lam[0, a, b] * y[b]
        for c in range(nv):
            tau[c] += J[rows[a], c] * F
    return R, p
