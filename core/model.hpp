// The kinematic-tree model: immutable flat arrays, built once from the Python model (dynamics/model.py) and
// shared by every thread (the workspace is Data, data.hpp).
//
// Bodies are numbered so that parents[i] < i, hence every algorithm is one forward and/or one reverse loop over
// 0..nb-1.  Body i is moved by joint i; its frame is the joint frame.  parents[i] == -1: attached to the world.
//
//   field          size        meaning
//   parents        nb          parent body, -1 for the world
//   jtype          nb          joint type (joints.hpp)
//   q_idx, v_idx   nb          first coordinate of joint i in q and in v
//   nv_j           nb          number of velocity coordinates of joint i
//   Xrot, Xpos     nb          joint frame in the parent body frame at q = 0 (rotation, origin)
//   axis           nb          unit joint axis in the joint (= body) frame (zero for free and spherical joints)
//   S              nv          motion subspace per velocity coordinate, (w, v) in the body frame
//   I              nb          rigid-body inertia (m, h = m c, Io about the body origin), body frame
//   XK, XKK        nb          Xrot [axis]x and Xrot [axis]x^2 for revolute and planar joints (zero otherwise), so
//                              that R(q) = Xrot + sin q XK + (1 - cos q) XKK
//   gravity                    in the world frame
//   lower, upper   nv          position limits of 1-dof joints (-inf/inf when absent or not a 1-dof joint)
//   frame_*        nf          every frame: the body it is fixed to (-1: the world), its kind (FrameKind) and
//                              its pose (R, p) in that body's frame
#pragma once

#include <string>
#include <vector>

#include "spatial.hpp"

namespace core {

// What a frame's pose needs from its body's: nothing (the body's own frame), an offset, a full pose, or
// nothing of the body at all (fixed in the world).
enum FrameKind { FRAME_BODY = 0, FRAME_SHIFTED = 1, FRAME_ROTATED = 2, FRAME_WORLD = 3 };

struct Model {
    int nb = 0, nq = 0, nv = 0;
    std::vector<int> parents, jtype, q_idx, v_idx, nv_j;
    std::vector<Mat3> Xrot, XK, XKK;
    std::vector<Vec3> Xpos, axis;
    std::vector<Motion> S;
    std::vector<Inertia> I;
    Vec3 gravity;
    std::vector<double> lower, upper;
    int nf = 0;
    std::vector<int> frame_body, frame_kind;
    std::vector<Mat3> frame_R;
    std::vector<Vec3> frame_p;
    // derived by check(): whether a joint has nq != nv (free, spherical, planar: a unit block in q)
    bool has_unit_blocks = false;
    // derived by check(), nb: k in {0, 1, 2} when joint i is revolute about the body's own x, y or z axis (S_i is
    // exactly the unit angular motion e_k, as for every revolute joint of Panda, UR5 and Talos), else -1; the
    // kernels then skip the products with S's zeros (joints.hpp)
    std::vector<int> axis_k;
};

// Checks every index and size of a model filled from outside (the bindings) and derives what is derived;
// throws std::invalid_argument naming the first inconsistency.  After it, no algorithm reads out of bounds.
void check(Model& model);

// lam[k]: Featherstone's lambda over velocity coordinates (the previous coordinate of a multi-coordinate joint, else
// the parent joint's last; -1 at the root): the branch-induced sparsity of M, whose nonzeros (k, j) have j on k's
// chain or k on j's.
void dof_parents(const Model& model, int* lam);

}  // namespace core
