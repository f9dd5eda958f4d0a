// Derivatives of the generalised contact force tau_c = sum_k A_k^T F_k for the simulation's Jacobian (the C++ side of
// dynamics/contact/force_derivatives.py, whose docstring derives them).  A_k (3 x nv): the Jacobian of contact k's
// relative point velocity, v_rel = A_k v; G_k = dF_k/dv_rel, F_x = dF_k/dx:
//
//     d tau_c / dv = sum_k A_k^T G_k A_k                 exact
//     d tau_c / dq ~ -sum_k A_k^T F_x (n^T A_k)          the contact's stiffness (Radau's Newton matrix)
#pragma once

#include <cstdint>
#include <vector>

#include "contact/narrow_phase.hpp"
#include "model.hpp"

namespace core::contact {

// The scratch of contact_force_derivatives for nv velocities.
struct ForceDerivativesWork {
    std::vector<double> A, GA, nA;  // 3 x nv, 3 x nv, nv
    std::vector<int> dofs;          // nv: the dofs that move a contact's point
    explicit ForceDerivativesWork(int nv = 0) : A(3 * nv), GA(3 * nv), nA(nv), dofs(nv) {}
};

// dv = d tau_c/dv and dq = its stiffness part of d tau_c/dq (nv x nv, row-major, tangent space) of contacts 0..n-1
// of buf at velocity v, the bodies' world poses oMi at q.
void contact_force_derivatives(const Model& model, int64_t n, const ContactBuffer& buf, const int64_t* pair_body,
                               const double* mat, const Transform* oMi, const double* v, double* dq, double* dv,
                               ForceDerivativesWork& w);

}  // namespace core::contact
