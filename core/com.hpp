// The robot's centre of mass, its velocity and its Jacobian, world frame (Pinocchio's centerOfMass and
// jacobianCenterOfMass).  With body i at world pose (oR_i, op_i), mass m_i, first moment h_i = m_i c_i (body
// frame), m = sum m_i:
//     com  = sum_i (oR_i h_i + m_i op_i) / m
//     vcom = sum_i oR_i (m_i v_i + w_i x h_i) / m            (body velocities (w_i, v_i) in body frames)
//     Jcom[:, k] = (m_s v_k + w_k x H_s) / m                  (k a velocity coordinate of joint i)
// where (w_k, v_k) is column k of the spatial world Jacobian and m_s, H_s = sum (oR_j h_j + m_j op_j) are the mass
// and world first moment of the subtree of i, accumulated from the leaves in (O(n)).
#pragma once

#include "data.hpp"

namespace core {

enum ComQuantity { COM = 0, COM_VELOCITY = 1, COM_JACOBIAN = 2 };

// out: the com (3), vcom (3, v read) or Jcom (3 x nv, row-major) at q.
void center_of_mass(const Model& model, Data& data, const double* q, const double* v, int what, double* out);

}  // namespace core
