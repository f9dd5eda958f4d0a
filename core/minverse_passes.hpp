// M^-1's two passes (minverse.hpp has the equations) over world axes and inertias a caller has computed: the fused
// ABA derivatives (aba_derivatives.cpp) have them from their own forward pass, so M^-1 costs no second one;
// inverse_mass_matrix() (minverse.cpp) runs them after its own world pass.
#pragma once

#include "data.hpp"

namespace core {

// The backward pass, from Data::Sw (nv, S_k in the world), Data::IA (nb, each body's own inertia about the world
// origin, 6x6) and Data::nsub (nb, the subtree's coordinate count): M^-1's rows from the diagonal on, the
// articulated inertias.  Returns -1, or a body whose joint's D is not positive (M is singular).
int minverse_backward_pass(const Model& model, Data& data, double* Minv);

// The forward pass (the backward one done): the upper triangle, then its mirror below.
void minverse_forward_pass(const Model& model, Data& data, double* Minv);

}  // namespace core
