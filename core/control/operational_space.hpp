// Operational-space control of a frame (Khatib 1987, "A unified approach for motion and force control of robot
// manipulators: the operational space formulation"; Featherstone 2008, sec. 9.3), the kernel behind
// dynamics.torques.OperationalSpace and Target.
//
// The task x is the frame's position (and orientation) in the world, with velocity J v, J the frame's Jacobian at
// "local_world_aligned" (jacobians.hpp) restricted to the task rows (of [linear; angular]), and
// acceleration xdd = J vd + Jdot v (Jdot v: the frame's bias acceleration).  With M vd + b = tau
// (b = C v + g minus the passive torques the simulator adds), the task-space dynamics are
//
//     F = Lambda xdd + mu + p,     Lambda = (J M^-1 J^T)^-1,     mu + p = Lambda (J M^-1 b - Jdot v),
//
// and the controller commands the task acceleration xdd* = xdd_d + Kd edot + Kp e, plus a posture task in the
// dynamically consistent null space (N = 1 - J^T Jbar^T, Jbar = M^-1 J^T Lambda, so J M^-1 N = 0):
//
//     tau = J^T (Lambda xdd* + mu + p) + N tau_0,     tau_0 = b + tau_p,     tau_p = Kp0 (q_0 - q) - Kd0 v.
//
// The posture is a joint stiffness (N m/rad): at rest the posture error that the task forces on the arm is the
// stiffness-weighted least-squares one (N tau_p = 0: Kp0 e in the range of J^T), so every joint shares the task's
// motion by its stiffness, not by its inertia (an acceleration-level posture M a_0 would let the light wrist take
// it all).  Expanding N (N b + J^T Lambda J M^-1 b = b), the same torque is
//
//     tau = ID(q, v, 0) + tau_p + J^T Lambda (xdd* - Jdot v - J M^-1 tau_p)                           (*)
//
// (ID the RNEA), which is what the kernel evaluates: one RNEA, one M^-1
// (minverse.hpp), one Jacobian, one Jdot v, and an r x r solve (r <= 6 task rows).  The closed
// loop is xdd = xdd* exactly for the model, i.e. e'' + Kd e' + Kp e = 0 per task row, and N tau_p drives the
// directions the task leaves free.
//
// Errors: e = p_d - p for the position; for the orientation e = log(R_d R^T) (world axes,
// rotation_log) and edot = w_d - w, exact to first order in the error.  When J M^-1 J^T
// is singular (the frame at a singularity of its task rows: a condition number above
// MAX_CONDITION, as for operational_space_inertia) the torque is NaN
// and the simulation stops with a non-finite status; ``damping`` d > 0 uses (J M^-1 J^T + d 1)^-1 instead.
#pragma once

#include "sources.hpp"

namespace core::control {

constexpr double MAX_CONDITION = 1e8;  // dynamics.task_space.MAX_CONDITION

// The reference orientation R_d and its angular velocity w_d (world) at t (the geodesic between samples, held at
// rest outside [t_0, t_N-1]).
void orientation_at(const Source& src, double t, Mat3& Rd, Vec3& wd);
// x_ref (3 x 3) = [p_d; pdot_d; pddot_d] at t (the end positions held at rest outside the reference's times).
void task_reference_at(const Source& src, double t, double* x_ref);
// tau (nv) by the law above, tau_passive the passive torques at (q, v).  Returns the frame's world pose; leaves J,
// M^-1, tau_p, J M^-1, y and Lambda in ws (the derivatives read them).
Transform operational_space_torques(const Model& model, const Source& src, const Vec3& gravity, SourceWorkspace& ws,
                                    double t, const double* q, const double* v, const double* tau_passive, double* tau);

}  // namespace core::control
