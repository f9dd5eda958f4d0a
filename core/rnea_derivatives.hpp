// Analytical derivatives of inverse dynamics (Carpentier and Mansard, "Analytical derivatives of rigid body
// dynamics algorithms", RSS 2018; Pinocchio's computeRNEADerivatives).
//
//     tau = RNEA(q, v, a) = M(q) a + C(q, v) v + g(q) - sum_i J_i^T f_ext_i
//     dtau/dq (in the tangent space), dtau/dv, dtau/da = M
//
// Everything is in the world frame (motions and forces at the world origin), so that moving a joint moves its
// whole subtree rigidly.  A q derivative is along q (+) dq with dq in the joint's own frame (the local tangent, as
// integrate and Pinocchio): the column of coordinate k of joint i is the world motion J_k = oX_i S_k of its axis.
//
// Forward pass (root out; p the parent of body i, ov_0 = 0, oa_0 = (0, -g)):
//     J_k   = oX_i S_k
//     ov_i  = ov_p + J_i qd_i,     oa_i = oa_p + J_i qdd_i + ov_i x (J_i qd_i)
//     dV_k  = ov_p x J_k           the velocity change of the subtree along a q_k move, its rigid part taken out
//     dAq_k = oa_p x J_k + ov_p x dV_k,     dAv_k = ov_i x J_k + dV_k
//     f_i   = Y_i oa_i + ov_i x* Y_i ov_i - oX_i^-T f_ext_i          (Y_i the body's inertia in the world frame)
//     dY_i  = ov_i x* Y_i - Y_i ov_i x + (Y_i ov_i) x*-matrix = [[B_i, 0], [-2 [hf_i]x, 0]]
//             with (hn_i, hf_i) = Y_i ov_i and B_i = [w] Io - Io [w] - [vl][h] - [h][vl] - [hn]  (ov_i = (w, vl))
// Backward pass (leaves in), Y_i, dY_i and F_i summed over the subtree of i:
//     tau_k = J_k^T F_i
//     Fa_k = Y_i J_k,   Fv_k = dY_i J_k + Y_i dAv_k,   Fq_k = dY_i dV_k + Y_i dAq_k
//     rows r of i or of an ancestor, columns k of i:  M[r, k] = J_r^T Fa_k,  dtau_r/dv_k = J_r^T Fv_k,
//         dtau_r/dq_k = J_r^T Fq_k, where for r above i Fq_k also carries J_k x* F_i (the rigid motion of the
//         subtree's forces; at r in i it cancels with the motion of J_r itself)
//     rows k of i, columns c of a strict ancestor:  dtau_k/dv_c = (Y_i J_k)^T dAv_c + (dY_i^T J_k)^T J_c,
//         dtau_k/dq_c = (Y_i J_k)^T dAq_c + (dY_i^T J_k)^T dV_c
// Entries between coordinates of different branches are zero.  Cost O(n d) for n coordinates at tree depth d.
#pragma once

#include "derivatives_data.hpp"

namespace core {

// dtau_dq, dtau_dv and M (nv x nv each, row-major, every entry written) at (q, v, a).  f_ext: nb rows
// [force, torque] (the API's order) in each body's frame, or null.
void rnea_derivatives(const Model& model, DerivativesData& data, const double* q, const double* v, const double* a,
                      const Vec3& gravity, const double* f_ext, double* dtau_dq, double* dtau_dv, double* M);

// The forward pass alone: every per-body field of the workspace but the composites, and J, dV, dAq, dAv (the
// kinematics derivatives read them; kinematics_derivatives.hpp).
void derivatives_forward_pass(const Model& model, DerivativesData& data, const double* q, const double* v,
                              const double* a, const Vec3& gravity, const double* f_ext);

// The forward pass with each body's joint transform X_i (nb, body i in its parent) given, as the ABA's first pass
// leaves them in Data::X: the same numbers, without computing them again (aba_derivatives.cpp).
void derivatives_forward_pass(const Model& model, DerivativesData& data, const Transform* X, const double* v,
                              const double* a, const Vec3& gravity, const double* f_ext);

// The backward pass after a forward one: dtau_dq and dtau_dv (every entry written), not M (the ABA derivatives
// have no use for it).  It sums the subtrees' Y, dY and F into the workspace's per-body fields.
void rnea_derivatives_backward_pass(const Model& model, DerivativesData& data, double* dtau_dq, double* dtau_dv);

}  // namespace core
