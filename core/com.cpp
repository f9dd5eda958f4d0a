// The centre of mass, its velocity and its Jacobian (com.hpp has the equations).
#include "com.hpp"

#include "joints.hpp"
#include "kinematics.hpp"

namespace core {

static double inverse_mass(const Model& model) {
    double m = 0.0;
    for (int i = 0; i < model.nb; ++i) m += model.I[i].m;
    return m > 0.0 ? 1.0 / m : 0.0;
}

void center_of_mass(const Model& model, Data& data, const double* q, const double* v, int what, double* out) {
    const double inv_m = inverse_mass(model);
    Vec3 c;
    for (int i = 0; i < model.nb; ++i) {  // world poses; the subtree sums H (in data.Ic[i].h) and masses start
        world_pose(model, data, i, q);
        const Transform &X = data.X[i], &oM = data.oMi[i];
        const Inertia& I = model.I[i];
        const Vec3 H = rot(oM.R, I.h) + I.m * oM.p;  // the body's world first moment
        if (what == COM) {
            c = c + H;
        } else if (what == COM_VELOCITY) {  // momentum oR (m v + w x h)
            const int par = model.parents[i];
            Motion vi = par >= 0 ? motion_to_child(X, data.v[par]) : Motion{};
            vi = vi + joint_motion(model, i, v);
            data.v[i] = vi;
            c = c + rot(oM.R, I.m * vi.v + cross(vi.w, I.h));
        }
        data.Ic[i].h = H;
        data.Ic[i].m = I.m;
    }
    if (what != COM_JACOBIAN) {
        const Vec3 r = inv_m * c;
        out[0] = r.x, out[1] = r.y, out[2] = r.z;
        return;
    }
    for (int i = model.nb - 1; i >= 0; --i) {  // subtree masses and world first moments
        const int par = model.parents[i];
        if (par >= 0) {
            data.Ic[par].m += data.Ic[i].m;
            data.Ic[par].h = data.Ic[par].h + data.Ic[i].h;
        }
    }
    const int nv = model.nv;
    for (int i = 0; i < model.nb; ++i) {
        const Transform& oM = data.oMi[i];
        const Vec3& Hs = data.Ic[i].h;
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            const Vec3 w = rot(oM.R, model.S[k].w);
            const Vec3 vk = rot(oM.R, model.S[k].v) + cross(oM.p, w);
            const Vec3 col = inv_m * (data.Ic[i].m * vk + cross(w, Hs));
            out[k] = col.x, out[nv + k] = col.y, out[2 * nv + k] = col.z;
        }
    }
}

}  // namespace core
