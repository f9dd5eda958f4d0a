// Analytical derivatives of forward dynamics (Carpentier and Mansard, RSS 2018; Pinocchio's computeABADerivatives).
//
//     a = ABA(q, v, tau) = M(q)^-1 (tau - C(q, v) v - g(q) + J^T f_ext)
//
// Differentiating RNEA(q, v, ABA(q, v, tau)) = tau at a fixed tau:
//
//     da/dq = -M^-1 dtau/dq (q, v, a),    da/dv = -M^-1 dtau/dv (q, v, a),    da/dtau = M^-1
//
// with dtau/dq, dtau/dv the RNEA derivatives (rnea_derivatives.hpp) at the ABA's acceleration a (aba.hpp) and M^-1
// by the articulated-body approach (minverse.hpp).  q derivatives are in the tangent space (nv columns, along
// q (+) dq with dq in each joint's frame), as Pinocchio's.
//
// Fused as Pinocchio's computeABADerivatives is, so that nothing is computed twice:
//   the ABA (aba.hpp, body frame): a, and every joint transform X_i;
//   pass 1, forward:  from the X_i, the world poses, axes J_k = oX_i S_k, velocities, accelerations at a, inertias
//                     Y_i and forces: the RNEA derivatives' forward pass, whose J_k and Y_i are also M^-1's inputs;
//   pass 2, backward: M^-1's rows with the articulated inertias (minverse_passes.hpp);
//   pass 3, backward: the RNEA derivatives' blocks with the composite inertias (M itself is not needed);
//   pass 4, forward:  M^-1's columns;
//   then da/dq = -M^-1 dtau/dq and da/dv = -M^-1 dtau/dv in one product, each entry summed over k in increasing
//   order, leaving out the zero blocks between branches.
// The ABA stays the body-frame one that forward_dynamics runs, so a, and with it every derivative, is bit for bit
// what the unfused ABA, inverse_mass_matrix, rnea_derivatives and a plain product give.  (A world-frame ABA, as
// Pinocchio's and the numba kernel's, rounds a differently: da/dq moved by up to 4e-13 of its largest entry on real
// robots, 3.6e-12 on random trees.)
#pragma once

#include "derivatives_data.hpp"

namespace core {

// da_dq, da_dv and Minv (nv x nv each, row-major) at (q, v, tau); f_ext as in rnea_derivatives() or null.  Returns
// -1, or the index of a body whose joint makes M singular (then nothing is valid).
int aba_derivatives(const Model& model, Data& data, DerivativesData& dd, const double* q, const double* v,
                    const double* tau, const Vec3& gravity, const double* f_ext, double* da_dq, double* da_dv,
                    double* Minv);

}  // namespace core
