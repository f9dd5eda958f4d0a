// The inverse of the mass matrix, computed directly in O(n^2) by the articulated-body approach (Carpentier &
// Mansard, "Analytical derivatives of rigid body dynamics algorithms", RSS 2018; Pinocchio's computeMinverse).
//
// Column c of M^-1 is the ABA's answer to tau = e_c at v = 0 without gravity; all columns are run at once, in
// the world frame (motion axes S_i = oX_i S_i^body, inertias about the world origin), so no per-column spatial
// transform is needed.  F_i (a 6-vector per column) is the articulated bias force of the subtree of i, nonzero
// only in the subtree's columns sub(i) (contiguous from i's own, depth-first order); A_i the acceleration:
//   backward (leaves in):  U_i = I^A_i S_i,  D_i = S_i^T U_i,
//                          M^-1[i, sub(i)] = D_i^-1 (E_i - S_i^T F_i)        (E_i: the identity at i's dofs)
//                          I^A_p += I^A_i - U_i D_i^-1 U_i^T,   F_p += F_i + U_i M^-1[i, sub(i)]
//   forward (root out):    M^-1[i, c] -= (U_i D_i^-1)^T A_p[:, c],   A_i = A_p + S_i M^-1[i, c]   (c >= i)
// The forward pass computes the upper triangle, the lower is its mirror.  Cost O(n d) backward, O(n^2) forward.
#pragma once

#include "data.hpp"

namespace core {

// Minv (nv x nv, row-major) at q.  Returns -1, or a body whose joint's D is not positive (M is singular).
int inverse_mass_matrix(const Model& model, Data& data, const double* q, double* Minv);

}  // namespace core
