// Analytical state derivatives of the operational-space controller (operational_space.hpp), for a fixed base of
// 1-dof joints (nq = nv; other models return false and are differenced by the caller).
//
// With F = Lambda y the task force, u = J^T F and s = M^-1 (u + tau_p), differentiating
//     tau = ID(q, v, 0) + tau_p - tau_passive + J^T F,   A = J M^-1 J^T + d 1,   Lambda = A^-1,
//     y = xdd_d + Kd (xd_d - J v) + Kp e - Jdot v - J M^-1 tau_p,   tau_p = Kp0 (q_0 - q) - Kd0 v
// (dLambda = -Lambda dA Lambda, dM^-1 = -M^-1 dM M^-1) gives
//     dtau/dv   = dID/dv - Kd0 - dtau_passive/dv + J^T Lambda (-Kd J - d(Jdot v)/dv + J M^-1 Kd0)
//     dtau/dq_m = dID/dq_m + Kp0 e_m' - dtau_passive/dq_m + G_m + J^T Lambda X_m,
//     X_m = -Kd dJ_m v + Kp de/dq_m - d(Jdot v)/dq_m - dJ_m s + J M^-1 (dM_m s - G_m + Kp0 e_m)
// with dJ_m = dJ/dq_m, G_m = dJ_m^T F (J^T moved at fixed F), dM_m s = d(M s)/dq_m the RNEA's q derivative at
// (q, 0, s) without gravity, e_m the m-th unit vector; the rows are the task's (r <= 6), Kd, Kp its gains.
//
// The frame's kinematics (Featherstone 2008, ch. 2; world frame, world origin): joint j's axis S_j = (w_j, v_j)
// follows from the Jacobian at the frame origin p (J^v_j = v_j + w_j x p), and moving an ancestor m (m <= j on
// the frame's path) moves it by dS_j/dq_m = S_m x S_j.  With V_{<m}, V_{>=m} the sums of S_j v_j before m and from
// m on, and T_m = sum_{k >= m} v_k S_k x V_{>k}:
//     dJ_j/dq_m = ([m <= j] S_m x S_j at p) + w_j x J^v_m in the linear rows     (p moves by J^v_m)
//     Jdot v    = A at p (classical): (A^v + A^w x p + w x v_p, A^w),  A = T_0,  v_p = J^v v
//     dA/dq_m   = S_m x T_m + V_{<m} x (S_m x V_{>=m}),    dA/dv_m = S_m x (V_{>=m} - V_{<m})
// de/dq_m: -J^v_m for the position rows, -Jr(e_o)^-1 w_m for the orientation error e_o = log(R_d R^T).  Off the
// frame's path J is zero and so is every term.  Two RNEA derivatives and O(r nv^2) more.  The order of operations
// is the numba kernels' (dynamics/control/operational_space_derivatives.py), so the results are the same bits.
#pragma once

#include "sources.hpp"

namespace core::control {

// dq = dtau/dq, dv = dtau/dv (nv x nv, row-major) at (t, q, v); false (nothing written) unless nq = nv.  NaN where
// the torque is NaN (a singular task or M).
bool operational_space_derivatives(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws,
                                   double t, const double* q, const double* v, double* dq, double* dv);

}  // namespace core::control
