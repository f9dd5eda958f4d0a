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
#pragma once

#include "derivatives_data.hpp"

namespace core {

// da_dq, da_dv and Minv (nv x nv each, row-major) at (q, v, tau); f_ext as in rnea_derivatives() or null.  Returns
// -1, or the index of a body whose joint makes M singular (then nothing is valid).
int aba_derivatives(const Model& model, Data& data, DerivativesData& dd, const double* q, const double* v,
                    const double* tau, const Vec3& gravity, const double* f_ext, double* da_dq, double* da_dv,
                    double* Minv);

}  // namespace core
