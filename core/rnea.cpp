// Inverse dynamics (RNEA) and the gravity torques (rnea.hpp has the equations).
#include "rnea.hpp"

#include "cpu_dispatch.hpp"
#include "joints.hpp"

namespace core {

namespace {

// Body i's step of the forward pass (data.hpp's forward_body) and RNEA's forward step in one, so that v_i and c_i
// stay in registers (c_i is not stored; X_i, v_i, a_i and f_i are).  K: the body axis of a revolute joint about
// one (Model::axis_k), fixed at compile time so that joint_motion's, velocity_product's and joint_project's choices
// of the axis fold away; -1 for any other joint (their general paths).  The same operations in the same order as
// the separate steps: the same bits.
template <int K>
ALWAYS_INLINE void rnea_body(const Model& model, Data& data, int i, const double* q, const double* v,
                             const double* a, const Motion& a0, const double* f_ext, bool with_v, bool with_a) {
    Transform X;
    if constexpr (K >= 0)
        X = {rodrigues(model, i, data.sin_q[i], data.vers_q[i]), model.Xpos[i]};
    else
        X = transform_after_sines(model, data, i, q);  // (a revolute joint off the body axes: its sines taken too)
    data.X[i] = X;
    const int par = model.parents[i];
    Motion ai = motion_to_child(X, par < 0 ? a0 : data.a[par]);
    if (with_a) {
        if constexpr (K >= 0)
            ai = ai + Motion{scaled_axis(K, 0.0 + a[model.v_idx[i]]), {}};
        else
            ai = ai + joint_motion(model, i, a);
    }
    const Inertia& I = model.I[i];
    Force fi;
    if (with_v) {
        Motion vi = motion_to_child(X, par < 0 ? Motion{} : data.v[par]);
        Motion ci;
        if constexpr (K >= 0) {
            const double x = 0.0 + v[model.v_idx[i]];
            vi = vi + Motion{scaled_axis(K, x), {}};
            ci = {cross_axis(vi.w, K, x), cross_axis(vi.v, K, x)};
        } else {
            const Motion vJ = joint_motion(model, i, v);
            vi = vi + vJ;
            ci = velocity_product(model, i, vi, vJ);
        }
        data.v[i] = vi;
        ai = ai + ci;
        fi = I * ai;
        fi = fi + cross(vi, I * vi);
    } else {
        fi = I * ai;
    }
    if (f_ext) fi = fi - force_from_api(f_ext + 6 * i);
    data.a[i] = ai;
    data.f[i] = fi;
}

}  // namespace

// Compiled three times, portable, AVX2 and AVX-512F (no fused multiply-add: the same bits), the CPU choosing when
// the library loads (cpu_dispatch.hpp); the steps and the spatial algebra are flattened into each copy.
AVX512_CLONE FLATTEN void rnea(const Model& model, Data& data, const double* q, const double* v, const double* a,
                               const Vec3& gravity, const double* f_ext, bool with_v, bool with_a, double* tau) {
    const Motion a0 = {{}, -gravity};  // the world accelerates up
    revolute_sines(model, data, q);  // first (data.hpp; 5-9 % of the batched time of UR5, Panda and Talos)
    for (int i = 0; i < model.nb; ++i) {
        switch (model.axis_k[i]) {
            case 0: rnea_body<0>(model, data, i, q, v, a, a0, f_ext, with_v, with_a); break;
            case 1: rnea_body<1>(model, data, i, q, v, a, a0, f_ext, with_v, with_a); break;
            case 2: rnea_body<2>(model, data, i, q, v, a, a0, f_ext, with_v, with_a); break;
            default: rnea_body<-1>(model, data, i, q, v, a, a0, f_ext, with_v, with_a);
        }
    }
    for (int i = model.nb - 1; i >= 0; --i) {
        joint_project(model, i, data.f[i], tau);
        const int par = model.parents[i];
        if (par >= 0) data.f[par] = data.f[par] + force_to_parent(data.X[i], data.f[i]);
    }
}

void gravity_torques(const Model& model, Data& data, const double* q, const Vec3& gravity, double* tau) {
    for (int i = 0; i < model.nb; ++i) {
        Transform X = joint_transform(model, i, q);
        const int par = model.parents[i];
        data.X[i] = X;
        data.g[i] = rotT(X.R, par < 0 ? gravity : data.g[par]);
        data.Ic[i].h = model.I[i].h;  // the subtree's first moment H_i and mass M_i, from the leaves in
        data.Ic[i].m = model.I[i].m;
    }
    for (int i = model.nb - 1; i >= 0; --i) {
        const Vec3 &H = data.Ic[i].h, &g = data.g[i];
        const double M = data.Ic[i].m;
        joint_project(model, i, {cross(g, H), -M * g}, tau);  // -H x g = g x H
        const int par = model.parents[i];
        if (par >= 0) {
            data.Ic[par].h = data.Ic[par].h + (rot(data.X[i].R, H) + M * data.X[i].p);
            data.Ic[par].m += M;
        }
    }
}

}  // namespace core
