// Frame Jacobians and their time variation (jacobians.hpp has the equations).
#include "jacobians.hpp"

#include <algorithm>

#include "joints.hpp"
#include "kinematics.hpp"

namespace core {

Transform frame_jacobian(const Model& model, Data& data, const double* q, int f, int ref, const Vec3& point,
                         double* J) {
    const int nv = model.nv;
    const int n = support(model, data, model.frame_body[f]);
    for (int t = 0; t < n; ++t) world_pose(model, data, data.path[t], q);
    const Transform Tf = frame_pose(model, data, f);
    const Vec3 o = Tf.p + rot(Tf.R, point);
    for (int t = 0; t < n; ++t) {
        const int i = data.path[t];
        const Transform& oM = data.oMi[i];
        const Vec3 x = ref == WORLD ? -oM.p : o - oM.p;
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            Vec3 w = rot(oM.R, model.S[k].w);
            Vec3 v = rot(oM.R, model.S[k].v) + cross(w, x);
            if (ref == LOCAL) w = rotT(Tf.R, w), v = rotT(Tf.R, v);
            to_api({w, v}, J + k, nv);
        }
    }
    return Tf;
}

void frame_jacobian_time_variation(const Model& model, Data& data, const double* q, const double* v, int f,
                                   int ref, double* dJ) {
    const int nv = model.nv, body = model.frame_body[f];
    const int n = support(model, data, body);
    Motion ov;  // the world spatial velocity of path[t], at the world origin
    std::fill(dJ, dJ + 6 * nv, 0.0);
    for (int t = 0; t < n; ++t) {
        const int i = data.path[t];
        world_pose(model, data, i, q);
        const Transform& oM = data.oMi[i];
        ov = ov + motion_to_parent(oM, joint_motion(model, i, v));
        data.v[i] = ov;
    }
    const Transform T = frame_pose(model, data, f);
    const Motion ovb = n > 0 ? data.v[body] : Motion{};
    const Vec3 dp = ovb.v + cross(ovb.w, T.p);  // the frame origin's velocity
    for (int t = 0; t < n; ++t) {
        const int i = data.path[t];
        const Transform& oM = data.oMi[i];
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            const Motion Jk = motion_to_parent(oM, model.S[k]);
            const Motion d = cross(data.v[i], Jk);
            Motion out;
            if (ref == WORLD) {
                out = d;
            } else if (ref == LOCAL) {
                const Motion x = d - cross(ovb, Jk);
                out = {rotT(T.R, x.w), rotT(T.R, x.v - cross(T.p, x.w))};
            } else {
                out = {d.w, d.v - cross(T.p, d.w) - cross(dp, Jk.w)};
            }
            to_api(out, dJ + k, nv);
        }
    }
}

}  // namespace core
