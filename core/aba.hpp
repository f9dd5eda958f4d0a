// Forward dynamics by the Articulated Body Algorithm, O(n) (Featherstone 2008, sec. 7.3, Table 7.1).
//
//     a = M(q)^-1 (tau - C(q, v) v - g(q) + J^T f_ext)
//
// Pass 1 (forward): v_i = X_i v_p + S_i qd_i,  c_i = v_i x (S_i qd_i),  I^A_i = I_i,  p^A_i = v_i x* I_i v_i - f_ext_i.
// Pass 2 (reverse): U_i = I^A_i S_i,  D_i = S_i^T U_i,  u_i = tau_i - S_i^T p^A_i,
//                   I^a = I^A_i - U_i D_i^-1 U_i^T,  p^a = p^A_i + I^a c_i + U_i D_i^-1 u_i,
//                   I^A_p += X_i^T I^a X_i,  p^A_p += X_i^T p^a.
// Pass 3 (forward): a'_i = X_i a_p + c_i (a_0 = (0, -g)),  qdd_i = D_i^-1 (u_i - U_i^T a'_i),  a_i = a'_i + S_i qdd_i.
//
// A joint whose D_i is not positive definite (it carries no mass or inertia it could move) makes M singular:
// the algorithm stops and returns that body's index.
#pragma once

#include "data.hpp"

namespace core {

// qdd (nv) at (q, v, tau); f_ext as in rnea() or null; with_v = false: v is zero.  Returns -1, or the index of
// a body whose joint sees a singular articulated inertia (then qdd is not valid).
int aba(const Model& model, Data& data, const double* q, const double* v, const double* tau, const Vec3& gravity,
        const double* f_ext, bool with_v, double* qdd);

// The three passes, for callers that add forces between the first and the second (p^A_i -= f_i).
void aba_rigid_body_pass(const Model& model, Data& data, const double* q, const double* v, const double* f_ext,
                         bool with_v);
int aba_articulated_pass(const Model& model, Data& data, const double* tau);
void aba_acceleration_pass(const Model& model, Data& data, const Vec3& gravity, double* qdd);
// Instead of the other two: the RNEA's torques at zero joint accelerations from the first pass's X, c and p^A
// (with what was subtracted from p^A since), b = C(q, v) v + g(q) - sum_i J_i^T f_i:
//     a_i = X_i a_p + c_i  (a_0 = (0, -g)),   f_i = I_i a_i + p^A_i,   b_i = S_i^T f_i,   f_p += X_i^T f_i
// (the implicit Euler's M a = tau - b: a step that factors M needs no articulated inertias).  Writes data.a, data.f.
void aba_bias_pass(const Model& model, Data& data, const Vec3& gravity, double* b);

// IA[par] += X^T Ia X for a 6x6 (articulated) inertia Ia given in the child frame.  With Ia = [[A, B], [B^T, C]],
// A' = R A R^T, B' = R B R^T, C' = R C R^T and P = [p]x:
// X^T Ia X = [[A' - B'P - (B'P)^T - P C'P,  B' - (C'P)^T], [B'^T - C'P, C']].
void add_inertia_to_parent(const Transform& X, const Mat6& Ia, Mat6& IA_parent);

}  // namespace core
