// The workspace of the algorithms (Pinocchio's Data, MuJoCo's mjData): one per call or per thread, never shared.
// Fields are grouped by the pass that writes them; sizes in the comments (nb bodies, nv velocity coordinates).
// Every vector is in the frame its comment names; motions and forces in the core's order (spatial.hpp).
//
// The forward pass (forward_pass below) is written once and read by RNEA, ABA, the energies and the Coriolis
// matrix.  For one state, body i with parent p (Featherstone 2008, eqs. 5.7-5.8, constant S in body coordinates):
//
//     X_i = joint_transform(i, q)       body i in its parent's frame
//     v_i = X_i v_p + S_i qd_i          spatial velocity, body frame
//     c_i = v_i x (S_i qd_i)            velocity-product acceleration
#pragma once

#include <vector>

#include "joints.hpp"
#include "model.hpp"

namespace core {

struct Data {
    int nb = -1, nq = -1, nv = -1;  // the sizes it was made for

    // the forward pass
    std::vector<Transform> X;  // nb: body i in its parent's frame
    std::vector<Motion> v;     // nb: body velocity, body frame
    std::vector<Motion> c;     // nb: c_i = v_i x (S_i qd_i), body frame (zero when v is not computed)

    // RNEA, ABA's last pass, frame motions
    std::vector<Motion> a;  // nb: body acceleration (gravity as the world's upward acceleration), body frame
    std::vector<Force> f;   // nb: the force body i transmits to its parent, body frame

    // world poses (kinematics, the energies, the centre of mass, M^-1), and the support of a frame
    std::vector<Transform> oMi;  // nb: body i in the world
    std::vector<int> path;       // nb: a body's ancestors and itself, root first

    // CRBA and g(q): composite rigid-body inertias of the subtrees, body frame
    std::vector<Inertia> Ic;  // nb
    std::vector<Vec3> g;      // nb: gravity in body i's frame (g(q))

    // ABA (and M^-1 in the world frame): articulated inertias and bias forces, per joint U = IA S, D^-1, u
    std::vector<Mat6> IA;    // nb
    std::vector<Force> pA;   // nb
    std::vector<Force> U;    // nv: U = I^A S per velocity coordinate (a force)
    std::vector<Mat6> Dinv;  // nb: D^-1 of joint i in its top-left nv_j x nv_j block
    std::vector<double> u;   // nv

    // M^-1 (minverse.cpp): motion axes in the world, U D^-1, subtree sizes, F then A per column
    std::vector<Motion> Sw;   // nv
    std::vector<Force> UD;    // nv
    std::vector<int> nsub;    // nb
    std::vector<double> F;    // nb * nv * 6 (sized by minverse)

    // task space and inverse kinematics: Jacobians (6 x nv), M^-1 (nv x nv), J M^-1 (6 x nv), support columns
    std::vector<double> J, Jt, Minv, JM;
    std::vector<int> cols;  // nv

    // scratch vectors of size nv and nq
    std::vector<double> tmp_v, tmp_v2, tmp_q, tmp_q2;
    // sin q_i and 1 - cos q_i of the revolute joints (nb), taken before a pass (revolute_sines below: RNEA, the
    // ABA's first pass, the energies)
    std::vector<double> sin_q, vers_q;

    Data() = default;
    explicit Data(const Model& model) { resize(model); }
    void resize(const Model& model);
};

// The calling thread's workspace, sized for `model` (a single call's Data: no allocation once warm).
Data& thread_data(const Model& model);

// sin q_i and 1 - cos q_i of the revolute joints, into data.sin_q and data.vers_q, before a pass: independent calls
// the CPU overlaps, where on each body's path (a body's step is longer than the CPU's window) it waited for them in
// turn.  The same numbers as joint_transform's.
inline void revolute_sines(const Model& model, Data& data, const double* q) {
    for (int i = 0; i < model.nb; ++i)
        if (model.jtype[i] == JOINT_REVOLUTE) {
            const double qi = q[model.q_idx[i]];
            data.sin_q[i] = std::sin(qi), data.vers_q[i] = 1.0 - std::cos(qi);
        }
}

// X_i(q) with a revolute joint's sines taken by revolute_sines: joint_transform's numbers.
inline Transform transform_after_sines(const Model& model, const Data& data, int i, const double* q) {
    if (model.jtype[i] == JOINT_REVOLUTE) return {rodrigues(model, i, data.sin_q[i], data.vers_q[i]), model.Xpos[i]};
    return joint_transform(model, i, q);
}

// Body i's step of the forward pass after its transform data.X[i] (its parent's step done); without with_v the
// velocities are not written and c_i = 0 is.  Inline: RNEA, ABA and the energies call it once per body and state.
inline void forward_motion(const Model& model, Data& data, int i, const double* qd, bool with_v) {
    if (!with_v) {
        data.c[i] = Motion{};
        return;
    }
    const Transform& X = data.X[i];
    int par = model.parents[i];
    Motion v = motion_to_child(X, par < 0 ? Motion{} : data.v[par]);
    Motion vJ = joint_motion(model, i, qd);
    v = v + vJ;
    data.v[i] = v;
    data.c[i] = velocity_product(model, i, v, vJ);
}

// Body i's whole step: its transform, then forward_motion.
inline void forward_body(const Model& model, Data& data, int i, const double* q, const double* qd, bool with_v) {
    data.X[i] = joint_transform(model, i, q);
    forward_motion(model, data, i, qd, with_v);
}

// The forward pass over every body.
inline void forward_pass(const Model& model, Data& data, const double* q, const double* qd, bool with_v) {
    for (int i = 0; i < model.nb; ++i) forward_body(model, data, i, q, qd, with_v);
}

}  // namespace core
