// Frame Jacobians and their time variation (Featherstone 2008, sec. 4.3; Pinocchio's computeFrameJacobian and
// getFrameJacobianTimeVariation).
//
// J maps joint velocities to the frame's velocity, frame_velocity = J(q) v, rows [linear; angular].  Column k (a
// velocity coordinate of joint i on the frame's support; every other column is zero) is the motion subspace
// S_k of body i carried to the world:
//     w_k = oR_i S_k^w,    v_k(x) = oR_i S_k^v + w_k x (x - op_i)    (the velocity of the world point x)
// then expressed in the reference: WORLD takes x = 0 (the spatial column at the world origin);
// LOCAL_WORLD_ALIGNED takes x = o, the frame origin moved by `point` (in the frame's axes); LOCAL rotates that
// column into the frame's axes, oR_f^T.
//
// dJ/dt: the world column of coordinate k of joint j moves as dJ_k/dt = ov_j x J_k (ov_j the world spatial
// velocity of body j at the world origin).  LOCAL takes out the frame's own motion, (dJ_k - ov_b x J_k) seen
// in the frame; LOCAL_WORLD_ALIGNED also carries the frame origin's own velocity do/dt:
//     lin_k = dJ_k^v - o x dJ_k^w - do/dt x J_k^w,   ang_k = dJ_k^w.
#pragma once

#include "data.hpp"

namespace core {

// J (6 x nv, row-major) of frame f at q in reference ref, at `point` (frame axes) from the frame origin.  Only
// the support's columns are written: J must be zero elsewhere.  Returns the frame's world pose.
Transform frame_jacobian(const Model& model, Data& data, const double* q, int f, int ref, const Vec3& point,
                         double* J);

// dJ (6 x nv, row-major) = d/dt of frame_jacobian(q, f, ref) moving with v; zero outside the support.
void frame_jacobian_time_variation(const Model& model, Data& data, const double* q, const double* v, int f,
                                   int ref, double* dJ);

}  // namespace core
