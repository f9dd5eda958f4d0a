// Inverse dynamics (RNEA) and the gravity torques (rnea.hpp has the equations).
#include "rnea.hpp"

#include "cpu_dispatch.hpp"
#include "joints.hpp"

namespace core {

// Compiled twice, portable and AVX2 (no FMA: the same bits), the CPU choosing when the library loads
// (cpu_dispatch.hpp); the forward pass and the spatial algebra are flattened into each copy.
AVX2_CLONE FLATTEN void rnea(const Model& model, Data& data, const double* q, const double* v, const double* a, const Vec3& gravity,
          const double* f_ext, bool with_v, bool with_a, double* tau) {
    const Motion a0 = {{}, -gravity};  // the world accelerates up
    for (int i = 0; i < model.nb; ++i) {
        forward_body(model, data, i, q, v, with_v);
        const Transform& X = data.X[i];
        const int par = model.parents[i];
        Motion ai = motion_to_child(X, par < 0 ? a0 : data.a[par]);
        if (with_a) ai = ai + joint_motion(model, i, a);
        if (with_v) ai = ai + data.c[i];
        const Inertia& I = model.I[i];
        Force fi = I * ai;
        if (with_v) fi = fi + cross(data.v[i], I * data.v[i]);
        if (f_ext) fi = fi - force_from_api(f_ext + 6 * i);
        data.a[i] = ai;
        data.f[i] = fi;
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
