// Kinetic and potential energy.
//     T(q, v) = 1/2 sum_i v_i . I_i v_i          (body velocities v_i from the forward pass)
//     U(q)    = - sum_i m_i g . c_i^world        (c_i^world = p_i + R_i c_i, world pose of body i)
// With a fixed base the world is the root link's frame.
#pragma once

#include "data.hpp"

namespace core {

// (T, U) at (q, v): T when `kinetic` (v read), U when `potential`; 0 for the one not asked.
void energies(const Model& model, Data& data, const double* q, const double* v, const Vec3& gravity, bool kinetic,
              bool potential, double& T, double& U);

}  // namespace core
