// A Coriolis matrix C(q, v) with C v = bias_forces - g(q) and dM/dt - 2C skew-symmetric.
//
// C is not unique; this is the factorisation of Echeandia & Wensing (2021, "A numerical method for computing the
// Coriolis matrix", eq. 28), in body coordinates:
//     C = sum_i J_i^T [ I_i dJ_i + 1/2 ( v_i x* I_i + I_i v_i x + (I_i v_i) xbar ) J_i ]
// with J_i body i's Jacobian in its own frame, dJ_i its time derivative and (f xbar) v = v x* f.  Recursion for
// the Jacobian columns of the ancestors of i (parent p, joint velocity v_J = S_i qd_i):
//     J_i = X_i J_p (+ S_i on i's own columns),   dJ_i = X_i dJ_p - v_J x (X_i J_p)   (own columns: 0).
// Cost O(n d^2) for depth d: for analysis and control design, not for inner loops.
#pragma once

#include "data.hpp"

namespace core {

// C (nv x nv, row-major) at (q, v).
void coriolis_matrix(const Model& model, Data& data, const double* q, const double* v, double* C);

}  // namespace core
