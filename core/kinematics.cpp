// Forward kinematics of frames (kinematics.hpp has the equations).
#include "kinematics.hpp"

#include "joints.hpp"

namespace core {

void world_pose(const Model& model, Data& data, int i, const double* q) {
    const Transform X = joint_transform(model, i, q);
    data.X[i] = X;
    const int par = model.parents[i];
    data.oMi[i] = par < 0 ? X : compose(data.oMi[par], X);
}

int support(const Model& model, Data& data, int body) {
    int n = 0;
    for (int j = body; j >= 0; j = model.parents[j]) data.path[n++] = j;
    for (int t = 0; t < n / 2; ++t) std::swap(data.path[t], data.path[n - 1 - t]);
    return n;
}

Transform frame_pose(const Model& model, const Data& data, int f) {
    const int b = model.frame_body[f];
    switch (model.frame_kind[f]) {
        case FRAME_BODY: return data.oMi[b];  // most frames: a link's, its joint's
        case FRAME_WORLD: return {model.frame_R[f], model.frame_p[f]};
        case FRAME_SHIFTED: {
            const Transform& B = data.oMi[b];
            return {B.R, rot(B.R, model.frame_p[f]) + B.p};
        }
        default: return compose(data.oMi[b], {model.frame_R[f], model.frame_p[f]});
    }
}

void in_reference(int ref, const Transform& T, const Motion& m, Vec3& lin, Vec3& ang) {
    if (ref == LOCAL) {
        lin = m.v, ang = m.w;
        return;
    }
    Vec3 w0 = rot(T.R, m.w), v0 = rot(T.R, m.v);
    ang = w0;
    lin = ref == LOCAL_WORLD_ALIGNED ? v0 : v0 + cross(T.p, w0);
}

void store_pose(const Transform& X, double* T) {
    for (int r = 0; r < 3; ++r) {
        T[4 * r] = X.R[3 * r], T[4 * r + 1] = X.R[3 * r + 1], T[4 * r + 2] = X.R[3 * r + 2], T[4 * r + 3] = X.p[r];
        T[12 + r] = 0.0;
    }
    T[15] = 1.0;
}

void placements(const Model& model, Data& data, const double* q, double* out) {
    for (int i = 0; i < model.nb; ++i) world_pose(model, data, i, q);
    for (int f = 0; f < model.nf; ++f) store_pose(frame_pose(model, data, f), out + 16 * f);
}

void frame_placement(const Model& model, Data& data, const double* q, int f, double* out) {
    const int n = support(model, data, model.frame_body[f]);
    for (int t = 0; t < n; ++t) world_pose(model, data, data.path[t], q);
    store_pose(frame_pose(model, data, f), out);
}

void frame_motion(const Model& model, Data& data, const double* q, const double* v, const double* a, int f, int ref,
                  int what, bool classical, double* out) {
    const int n = support(model, data, model.frame_body[f]);
    Motion vi, ai;  // the parent's motion, then body i's
    for (int t = 0; t < n; ++t) {
        const int i = data.path[t];
        world_pose(model, data, i, q);
        const Transform& X = data.X[i];
        const Motion vJ = joint_motion(model, i, v);
        vi = motion_to_child(X, vi) + vJ;
        if (what != VELOCITY) {
            ai = motion_to_child(X, ai) + cross(vi, vJ);
            if (what == ACCELERATION) ai = ai + joint_motion(model, i, a);
        }
    }
    const Transform T = frame_pose(model, data, f);
    const Transform Xf = {model.frame_R[f], model.frame_p[f]};  // the frame in its body
    Vec3 lin, ang;
    in_reference(ref, T, motion_to_child(Xf, vi), lin, ang);  // the frame's own motion, local axes and origin
    if (what != VELOCITY) {
        Vec3 alin, aang;
        in_reference(ref, T, motion_to_child(Xf, ai), alin, aang);
        if (classical) alin = alin + cross(ang, lin);
        lin = alin, ang = aang;
    }
    to_api({ang, lin}, out);
}

}  // namespace core
