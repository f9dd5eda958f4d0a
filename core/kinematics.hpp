// Forward kinematics of frames: placements, velocities and accelerations (Featherstone 2008, sec. 4.1-4.2;
// Pinocchio's forwardKinematics, getFrameVelocity, getFrameAcceleration).
//
// Placements: body i's world pose composes its parent's with the joint transform, and a frame fixed to body b
// at (R_bf, p_bf) in it is
//     oR_i = oR_p R_i,   op_i = oR_p p_i + op_p,       oR_f = oR_b R_bf,   op_f = oR_b p_bf + op_b.
// Velocities and accelerations, body frame, along the frame's support (body b and its ancestors):
//     v_i = X_i v_p + S_i qd_i,    a_i = X_i a_p + S_i qdd_i + v_i x (S_i qd_i),     v_0 = a_0 = 0
// (no gravity: a_i is the true spatial acceleration).  The frame's own motion is X_fb (v_b, a_b), expressed in
// one of three references (Pinocchio's ReferenceFrame): LOCAL (the frame's axes, linear part of the frame
// origin's point), LOCAL_WORLD_ALIGNED (the frame origin's point, world axes) and WORLD (the spatial vector at
// the world origin).  The classical acceleration adds w x v to the linear part of the spatial one.
#pragma once

#include "data.hpp"

namespace core {

enum Reference { WORLD = 0, LOCAL = 1, LOCAL_WORLD_ALIGNED = 2 };
enum FrameMotion { VELOCITY = 0, ACCELERATION = 1, BIAS_ACCELERATION = 2 };

// data.oMi[i] = body i's world pose from its parent's (already there); data.X[i] its joint transform.
void world_pose(const Model& model, Data& data, int i, const double* q);

// data.path[0..n) = body's ancestors and body itself, root first; returns n (0 for the world, body -1).
int support(const Model& model, Data& data, int body);

// The world pose of frame f from its body's world pose in data.oMi.
Transform frame_pose(const Model& model, const Data& data, int f);

// A motion m given in the local frame at world pose T, in reference ref: (linear, angular).
void in_reference(int ref, const Transform& T, const Motion& m, Vec3& lin, Vec3& ang);

// out (nf x 4 x 4): every frame's world placement at q.
void placements(const Model& model, Data& data, const double* q, double* out);

// out (4 x 4): frame f's world placement at q, along its support only.
void frame_placement(const Model& model, Data& data, const double* q, int f, double* out);

// out (6): frame f's velocity, acceleration or bias acceleration (a not read) at (q, v, a) in reference ref,
// rows [linear; angular]; `classical` adds w x v to the linear part of an acceleration.
void frame_motion(const Model& model, Data& data, const double* q, const double* v, const double* a, int f, int ref,
                  int what, bool classical, double* out);

// T = [[R, p], [0, 1]] (4 x 4, row-major).
void store_pose(const Transform& X, double* T);

}  // namespace core
