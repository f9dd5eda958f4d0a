// Joint-space mass matrix by the Composite Rigid Body Algorithm (Featherstone 2008, sec. 6.2, Table 6.2).
//
//     M(q) = sum_i J_i^T I_i J_i
//
// Backward pass: the composite inertia of the subtree at i, I^c_i = I_i + sum_children X_c^T I^c_c X_c, kept as
// (m, h, Io) in body i's frame.  For each velocity coordinate k of joint i, F = I^c_i S_k gives
// M[k, dofs(i)] = S_i^T F, then F is carried to each ancestor j (F = X_j^T F) for M[k, dofs(j)] = S_j^T F.
#pragma once

#include "data.hpp"

namespace core {

// M (nv x nv, row-major) at q.  Entries between coordinates on different branches are not written: the
// caller zeroes M.
void crba(const Model& model, Data& data, const double* q, double* M);
// The same from the joint transforms a forward pass at q left in data.X (aba_rigid_body_pass's): the same bits.
void crba_from_placements(const Model& model, Data& data, double* M);

}  // namespace core
