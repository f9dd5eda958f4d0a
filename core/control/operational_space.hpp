// Operational-space control of a frame (Khatib 1987; Featherstone 2008, sec. 9.3), the kernel behind
// dynamics.torques.OperationalSpace and Target (dynamics/control/operational_space.py has the derivation).
//
// The task x is the frame's position (and orientation) in the world, velocity J v with J the frame's Jacobian at
// local_world_aligned restricted to the task rows, acceleration xdd = J vd + Jdot v.  The controller commands
// xdd* = xdd_d + Kd edot + Kp e and a posture torque tau_p = Kp0 (q_0 - q) - Kd0 v in the dynamically consistent
// null space; with b = ID(q, v, 0) - tau_passive the torque is
//     tau = ID(q, v, 0) + tau_p - tau_passive + J^T Lambda (xdd* - Jdot v - J M^-1 tau_p),  Lambda = (J M^-1 J^T + d 1)^-1
// one RNEA, one M^-1, one Jacobian, one Jdot v and an r x r solve (r <= 6 task rows).  Errors: e = p_d - p for the
// position, e = log(R_d R^T) (world axes) for the orientation, edot = w_d - w.  When J M^-1 J^T is singular (a
// condition number above MAX_CONDITION, as for operational_space_inertia) the torque is NaN.
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
