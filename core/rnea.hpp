// Inverse dynamics by the Recursive Newton-Euler Algorithm (Featherstone 2008, sec. 5.3, Table 5.1).
//
//     tau = M(q) a + C(q, v) v + g(q) - sum_i J_i^T f_ext_i
//
// Body-frame formulation; gravity enters as a fictitious upward acceleration of the world, a_0 = (0, -g).
// Forward pass, for each body i with parent p and joint velocity v_J = S_i qd_i:
//     v_i = X_i v_p + S_i qd_i
//     a_i = X_i a_p + S_i qdd_i + v_i x (S_i qd_i)
//     f_i = I_i a_i + v_i x* I_i v_i - f_ext_i
// Backward pass:  tau_i = S_i^T f_i,  f_p += X_i^T f_i.
#pragma once

#include "data.hpp"

namespace core {

// tau (nv) at (q, v, a).  f_ext: nb rows [force, torque] (the API's order) in each body's frame, or null.
// with_v = false (v is zero) skips the velocity products, with_a = false (a is zero) the joint accelerations:
// the caller promises those inputs are zero.
void rnea(const Model& model, Data& data, const double* q, const double* v, const double* a, const Vec3& gravity,
          const double* f_ext, bool with_v, bool with_a, double* tau);

// g(q): RNEA at v = a = 0, where each body's force reduces to the weight of its subtree.  With a_0 = (0, -g)
// every a_i = (0, -g_i), g_i = R_i^T g_p, so f_i summed over the subtree of i is (-H_i x g_i, -M_i g_i) with
// M_i, H_i the subtree's mass and first moment in frame i: tau_i = S_i^T (-H_i x g_i, -M_i g_i).
void gravity_torques(const Model& model, Data& data, const double* q, const Vec3& gravity, double* tau);

}  // namespace core
