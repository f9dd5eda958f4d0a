// Derivatives of frame kinematics and of the centre of mass (Pinocchio's computeForwardKinematicsDerivatives,
// getFrameVelocityDerivatives, getFrameAccelerationDerivatives, getCenterOfMassVelocityDerivatives).
//
// The forward pass of the RNEA derivatives (rnea_derivatives.hpp, without gravity) gives, in the world frame at the
// world origin, per velocity coordinate k of joint j: its axis J_k, and the changes of the subtree's velocity and
// acceleration that are not the rigid motion of the subtree, dV_k = ov_p x J_k, dAq_k = oa_p x J_k + ov_p x dV_k,
// dAv_k = ov_j x J_k + dV_k.  For a frame on body b and k on b's support (other columns are zero):
//
//     d ov_b / dq_k = dV_k + J_k x ov_b,          d ov_b / dv_k = J_k
//     d oa_b / dq_k = dAq_k + dV_k x ov_b + J_k x oa_b,   d oa_b / dv_k = dAv_k + J_k x ov_b,   d oa_b / da_k = J_k
//
// In the frame's references (kinematics.hpp): WORLD is the above; LOCAL applies oX_f^-1 to it after taking out the
// frame's own motion J_k x (.) (a rigid motion moves the frame too): d(oX_f^-1 ov)/dq_k = oX_f^-1 dV_k;
// LOCAL_WORLD_ALIGNED is the motion at the frame origin o_f in world axes, (w, v - o_f x w), whose q derivative
// also carries the origin's own motion do_f/dq_k = J_k^v + J_k^w x o_f.  Accelerations are spatial (Featherstone's),
// as Pinocchio's derivatives.
//
// Centre of mass (mass M, c_i the centre of body i, P_j and H_j the subtree sums of m_i dc_i/dt and m_i c_i, m_j
// the subtree's mass): d com/dq_k = (m_j J_k^v + J_k^w x H_j) / M and
//     M d(vcom)/dq_k = J_k^w x P_j + m_j dV_k^v + dV_k^w x H_j.
#pragma once

#include "derivatives_data.hpp"

namespace core {

// dv_dq, dv_dv (6 x nv each, rows [linear; angular], every entry written): the derivatives of frame f's velocity in
// reference ref (kinematics.hpp's Reference) at (q, v).
void frame_velocity_derivatives(const Model& model, Data& data, DerivativesData& dd, const double* q,
                                const double* v, int f, int ref, double* dv_dq, double* dv_dv);

// dv_dq, da_dq, da_dv, da_da (6 x nv each): the derivatives of frame f's velocity and spatial acceleration.
void frame_acceleration_derivatives(const Model& model, Data& data, DerivativesData& dd, const double* q,
                                    const double* v, const double* a, int f, int ref, double* dv_dq, double* da_dq,
                                    double* da_dv, double* da_da);

// dcom_dq, dvcom_dq (3 x nv each, world frame): the derivatives of the centre of mass and of its velocity.
void center_of_mass_derivatives(const Model& model, Data& data, DerivativesData& dd, const double* q,
                                const double* v, double* dcom_dq, double* dvcom_dq);

}  // namespace core
