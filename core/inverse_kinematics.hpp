// Inverse kinematics by damped least squares (resolved motion rate control made robust: Nakamura & Hanafusa
// 1986, Wampler 1986; the damping adapted as in Levenberg-Marquardt).
//
// The error of frame f at q towards the target pose (R_d, p_d), local_world_aligned (world axes at the frame
// origin):  e = [p_d - p(q); log(R_d R(q)^T)]  (only the first 3 rows for a position-only target).  Each
// iteration solves (J J^T + mu 1) y = e, steps dq = J^T y along the manifold (integrate) and, when asked, keeps
// 1-dof joints within their limits: a joint at a limit that the step would push further out is frozen (its
// column dropped) and the step solved again; what still overshoots is clamped.  A step that does not reduce |e|
// is refused and mu grows tenfold; an accepted one lowers mu tenfold, never below damping^2.  It stops when
// |e| < tol (converged), after max_iter iterations, or when no step reduces |e| any more (mu above MAX_MU, or a
// relative gain below 1e-12): stalled.
#pragma once

#include "data.hpp"

namespace core {

enum IkStatus { IK_CONVERGED = 0, IK_MAX_ITER = 1, IK_STALLED = 2 };
constexpr double IK_MAX_MU = 1e12;  // the damping mu beyond which no step is tried any more

struct IkResult {
    int status = IK_MAX_ITER, iterations = 0;
    double residual = 0.0, position_error = 0.0, orientation_error = 0.0;
};

// q (nq): the configuration found from q0 towards the target (R_d, p_d) for frame f; r = 6 (pose) or 3
// (position only).  limits: keep 1-dof joints within [lower, upper].
IkResult inverse_kinematics(const Model& model, Data& data, const double* q0, const Transform& target, int f, int r,
                            double tol, int max_iter, double damping, bool limits, double* q);

}  // namespace core
