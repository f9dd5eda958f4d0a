// Joint models in one place (Featherstone 2008, sec. 4.4, jcalc): a switch on the joint type per function,
// so a new joint type is one case in each function of this file (and its record in dynamics/joints.py).
//
// The body frame is the joint frame, so the transform parent -> body is the placement (Xrot, Xpos) followed
// by the joint's motion:
//   revolute:   R = Xrot Rot(axis, q) = Xrot + sin q XK + (1 - cos q) XKK, p = Xpos          (nq = nv = 1)
//   prismatic:  R = Xrot, p = Xpos + Xrot axis q                                             (nq = nv = 1)
//   free:       R = Xrot Rot(quat), p = Xpos + Xrot xyz, q = [x, y, z, qx, qy, qz, qw], v = [linear, angular]
//               in the body frame (Pinocchio's layout)                                       (nq = 7, nv = 6)
//   spherical:  R = Xrot Rot(quat), p = Xpos, q = [qx, qy, qz, qw], v = angular velocity      (nq = 4, nv = 3)
//   planar:     R = Xrot Rot(axis, theta), p = Xpos + Xrot (x u + y w), q = [x, y, cos, sin], v = [vx, vy, wz]
//               in the body frame, (u, w) the plane's in-plane directions (S's linear rows)  (nq = 4, nv = 3)
// The motion subspace S is constant in body coordinates, so the joint bias acceleration is zero (c_J = 0) and
// v_i x (S qd) is the only velocity-product term (eq. 5.8).
#pragma once

#include <cmath>

#include "model.hpp"

namespace core {

enum JointType { JOINT_REVOLUTE = 0, JOINT_PRISMATIC = 1, JOINT_FREE = 2, JOINT_SPHERICAL = 3, JOINT_PLANAR = 4 };
constexpr int JOINT_TYPES = 5;

// Coordinates of a joint type in q and in v; its neutral q (the identity) into q0[0..nq).
int joint_nq(int type);
int joint_nv(int type);
void joint_neutral(int type, double* q0);

// Xrot Rot(axis, theta) = X + s XK + t XKK for s = sin theta, t = 1 - cos theta (Rodrigues' formula).
inline Mat3 rodrigues(const Model& model, int i, double s, double t) {
    const Mat3 &X = model.Xrot[i], &A = model.XK[i], &B = model.XKK[i];
    Mat3 R;
    for (int k = 0; k < 9; ++k) R[k] = X[k] + s * A[k] + t * B[k];
    return R;
}

// Body i in its parent's frame at q.  Inline, as forward_body is: every tree algorithm calls it once per body
// and state, and as a call its transform went through memory twice (returned, then copied into Data).
inline Transform joint_transform(const Model& model, int i, const double* q) {
    const int k = model.q_idx[i];
    const Mat3& X = model.Xrot[i];
    const Vec3& p0 = model.Xpos[i];
    switch (model.jtype[i]) {
        case JOINT_REVOLUTE: return {rodrigues(model, i, std::sin(q[k]), 1.0 - std::cos(q[k])), p0};
        case JOINT_PRISMATIC: return {X, p0 + rot(X, q[k] * model.axis[i])};
        case JOINT_SPHERICAL: return {X * quaternion_rotation(q[k], q[k + 1], q[k + 2], q[k + 3]), p0};
        case JOINT_PLANAR: {
            double nrm = std::sqrt(q[k + 2] * q[k + 2] + q[k + 3] * q[k + 3]);
            const Motion &u = model.S[model.v_idx[i]], &w = model.S[model.v_idx[i] + 1];
            double x = q[k], y = q[k + 1];
            Vec3 d = {x * u.v.x + y * w.v.x, x * u.v.y + y * w.v.y, x * u.v.z + y * w.v.z};
            return {rodrigues(model, i, q[k + 3] / nrm, 1.0 - q[k + 2] / nrm), p0 + rot(X, d)};
        }
        default:  // JOINT_FREE
            return {X * quaternion_rotation(q[k + 3], q[k + 4], q[k + 5], q[k + 6]),
                    p0 + rot(X, {q[k], q[k + 1], q[k + 2]})};
    }
}

// x e_k, the unit vector e_k (k in {0, 1, 2}) scaled.
inline Vec3 scaled_axis(int k, double x) { return {k == 0 ? x : 0.0, k == 1 ? x : 0.0, k == 2 ? x : 0.0}; }

// S_i qd: the joint's motion in the body frame for rates (or accelerations) qd (indexed by v).  A revolute joint
// about a body axis (Model::axis_k) gives the loop's numbers, 0.0 + 1.0 x and zeros, without its products.
inline Motion joint_motion(const Model& model, int i, const double* qd) {
    const int axis = model.axis_k[i];
    if (axis >= 0) return {scaled_axis(axis, 0.0 + qd[model.v_idx[i]]), {}};
    Motion m;
    for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
        const Motion& s = model.S[k];
        double x = qd[k];
        m.w.x += s.w.x * x, m.w.y += s.w.y * x, m.w.z += s.w.z * x;
        m.v.x += s.v.x * x, m.v.y += s.v.y * x, m.v.z += s.v.z * x;
    }
    return m;
}

// tau[dofs of i] = S_i^T f: the generalised force the joint transmits.  About a body axis k: the moment's
// component k, which the sum's other terms (products with zeros) do not change, plus 0.0 so that a zero torque
// is +0 as the sum makes it.
inline void joint_project(const Model& model, int i, const Force& f, double* tau) {
    const int axis = model.axis_k[i];
    if (axis >= 0) {
        tau[model.v_idx[i]] = 0.0 + f.n[axis];
        return;
    }
    for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
        const Motion& s = model.S[k];
        tau[k] = s.w.x * f.n.x + s.w.y * f.n.y + s.w.z * f.n.z + s.v.x * f.f.x + s.v.y * f.f.y + s.v.z * f.f.z;
    }
}

// a x (x e_k) without the products with e_k's zeros: each non-zero component is the full cross product's.
inline Vec3 cross_axis(const Vec3& a, int k, double x) {
    switch (k) {
        case 0: return {0.0, a.z * x, -(a.y * x)};
        case 1: return {-(a.z * x), 0.0, a.x * x};
        default: return {a.y * x, -(a.x * x), 0.0};
    }
}

// c_i = v_i x (S_i qd) for the joint's motion vJ = S_i qd (eq. 5.8); about a body axis k, vJ = (x e_k, 0) and
// v x vJ = (w x x e_k, v x x e_k): 4 products instead of the full cross product's 18.
inline Motion velocity_product(const Model& model, int i, const Motion& v, const Motion& vJ) {
    const int axis = model.axis_k[i];
    if (axis < 0) return cross(v, vJ);
    const double x = vJ.w[axis];
    return {cross_axis(v.w, axis, x), cross_axis(v.v, axis, x)};
}

// A unit quaternion (or a planar joint's (cos, sin)) whose squared norm is below this is "zero".
constexpr double ZERO_QUATERNION_SQ = 1e-16;

// Joint i's coordinates in q are a configuration: its quaternion or (cos, sin) is not zero.
bool joint_config_ok(const Model& model, int i, const double* q);

// Joint i has position limits (1-dof joints; -inf/inf when the URDF gives none).
inline bool joint_limited(const Model& model, int i) {
    return model.jtype[i] == JOINT_REVOLUTE || model.jtype[i] == JOINT_PRISMATIC;
}

// -- the configuration manifold (configuration.hpp loops over the joints) ------------------------------------

// Joint i's chart coordinates after moving with velocity v for dt from q (the exponential of SE(3), SO(3),
// SE(2) for the free, spherical and planar joints; v dt for 1-dof joints).
void joint_integrate_delta(const Model& model, int i, const double* q, const double* v, double dt, double* delta);
// Joint i's part of q = q0 (+) delta in the chart (configuration.hpp).
void joint_retract(const Model& model, int i, const double* q0, const double* delta, double* q);
// Joint i's part of the chart tangent d with retract(q0, d) == q1.
void joint_difference(const Model& model, int i, const double* q0, const double* q1, double* out);
// Joint i's part of the tangent d with integrate(q0, d, 1) == q1 (Pinocchio's difference: log6, log3, log2).
void joint_log(const Model& model, int i, const double* q0, const double* q1, double* out);
// Joint i's part of d(delta)/dt for velocity v at q = retract(q0, delta): v for 1-dof joints; (R(q) v_lin,
// Jr(delta_theta)^-1 omega) for the free joint (the second part alone for the spherical joint); (R(theta) (vx, vy),
// wz) for the planar joint.
void joint_chart_rate(const Model& model, int i, const double* q, const double* delta, const double* v, double* out);
// mag[dofs of i] = |the coordinate of q that moves alone with each velocity coordinate in the chart| (an angle, a
// position), 0 for a quaternion's or a planar joint's angle: the scale of the simulation's relative tolerance.
void joint_magnitudes(const Model& model, int i, const double* q, double* mag);

}  // namespace core
