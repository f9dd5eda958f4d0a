// Derivatives of frame kinematics and of the centre of mass (kinematics_derivatives.hpp has the equations).
#include "kinematics_derivatives.hpp"

#include <algorithm>

#include "kinematics.hpp"
#include "rnea_derivatives.hpp"

namespace core {

namespace {

// The world motion X (a column of derivatives) in reference ref at the frame pose T, into column k of out (6 x nv,
// [linear; angular]).  For LOCAL_WORLD_ALIGNED with a motion m differentiated (m non-null), the frame origin's own
// motion along the column, dp = J^v + J^w x p, is taken out: lin -= dp x m^w.
void put(int ref, const Transform& T, const Motion& X, const Motion* J, const Motion* m, int nv, int k,
         double* out) {
    const Vec3& p = T.p;
    if (ref == WORLD) return to_api(X, out + k, nv);
    Vec3 lin = X.v - cross(p, X.w);
    if (ref == LOCAL) return to_api(Motion{rotT(T.R, X.w), rotT(T.R, lin)}, out + k, nv);
    if (m) lin = lin - cross(J->v + cross(J->w, p), m->w);
    to_api(Motion{X.w, lin}, out + k, nv);
}

// The world pose of frame f at q, and its body (data.path holds the body's support).
Transform frame_at(const Model& model, Data& data, const double* q, int f) {
    const int n = support(model, data, model.frame_body[f]);
    for (int t = 0; t < n; ++t) world_pose(model, data, data.path[t], q);
    return frame_pose(model, data, f);
}

void zero(double* x, long n) { std::fill(x, x + n, 0.0); }

}  // namespace

void frame_velocity_derivatives(const Model& model, Data& data, DerivativesData& d, const double* q,
                                const double* v, int f, int ref, double* dv_dq, double* dv_dv) {
    const int nv = model.nv, b = model.frame_body[f];
    zero(dv_dq, 6L * nv), zero(dv_dv, 6L * nv);
    if (b < 0) return;  // fixed in the world
    zero(data.tmp_v.data(), nv);  // a = 0: the accelerations are not read
    derivatives_forward_pass(model, d, q, v, data.tmp_v.data(), Vec3{}, nullptr);
    const Transform T = frame_at(model, data, q, f);
    const Motion& ov = d.ov[b];
    for (int j = b; j >= 0; j = model.parents[j])
        for (int k = model.v_idx[j]; k < model.v_idx[j] + model.nv_j[j]; ++k) {
            const Motion& J = d.J[k];
            if (ref == LOCAL)  // the frame's own motion J x ov taken out
                put(ref, T, d.dV[k], nullptr, nullptr, nv, k, dv_dq);
            else
                put(ref, T, d.dV[k] + cross(J, ov), &J, &ov, nv, k, dv_dq);
            put(ref, T, J, nullptr, nullptr, nv, k, dv_dv);
        }
}

void frame_acceleration_derivatives(const Model& model, Data& data, DerivativesData& d, const double* q,
                                    const double* v, const double* a, int f, int ref, double* dv_dq, double* da_dq,
                                    double* da_dv, double* da_da) {
    const int nv = model.nv, b = model.frame_body[f];
    for (double* x : {dv_dq, da_dq, da_dv, da_da}) zero(x, 6L * nv);
    if (b < 0) return;
    derivatives_forward_pass(model, d, q, v, a, Vec3{}, nullptr);
    const Transform T = frame_at(model, data, q, f);
    const Motion &ov = d.ov[b], &oa = d.oa[b];
    for (int j = b; j >= 0; j = model.parents[j])
        for (int k = model.v_idx[j]; k < model.v_idx[j] + model.nv_j[j]; ++k) {
            const Motion &J = d.J[k], &dV = d.dV[k];
            put(ref, T, d.dAv[k] + cross(J, ov), nullptr, nullptr, nv, k, da_dv);
            put(ref, T, J, nullptr, nullptr, nv, k, da_da);
            if (ref == LOCAL) {  // the frame's own motion J x (.) taken out of the q derivatives
                put(ref, T, dV, nullptr, nullptr, nv, k, dv_dq);
                put(ref, T, d.dAq[k] + cross(dV, ov), nullptr, nullptr, nv, k, da_dq);
            } else {
                put(ref, T, dV + cross(J, ov), &J, &ov, nv, k, dv_dq);
                put(ref, T, (d.dAq[k] + cross(dV, ov)) + cross(J, oa), &J, &oa, nv, k, da_dq);
            }
        }
}

void center_of_mass_derivatives(const Model& model, Data& data, DerivativesData& d, const double* q,
                                const double* v, double* dcom_dq, double* dvcom_dq) {
    const int nb = model.nb, nv = model.nv;
    zero(data.tmp_v.data(), nv);  // a = 0: the accelerations are not read
    derivatives_forward_pass(model, d, q, v, data.tmp_v.data(), Vec3{}, nullptr);
    // per body: its subtree's mass m_j, H_j = sum m_i c_i and P_j = sum m_i dc_i/dt, in the composites' fields
    double total = 0.0;
    for (int i = 0; i < nb; ++i) {
        const double m = model.I[i].m;
        const Vec3& h = model.I[i].h;
        const Vec3 c = m > 0.0 ? rot(d.oM[i].R, {h.x / m, h.y / m, h.z / m}) + d.oM[i].p : d.oM[i].p;
        const Vec3 cdot = d.ov[i].v + cross(d.ov[i].w, c);
        d.Y[i].m = m, d.Y[i].h = m * c, d.hf[i] = m * cdot;
        total += m;
    }
    for (int i = nb - 1; i >= 0; --i) {
        const int par = model.parents[i];
        if (par < 0) continue;
        d.Y[par].m += d.Y[i].m, d.Y[par].h = d.Y[par].h + d.Y[i].h, d.hf[par] = d.hf[par] + d.hf[i];
    }
    zero(dcom_dq, 3L * nv), zero(dvcom_dq, 3L * nv);
    for (int i = 0; i < nb; ++i) {
        const double ms = d.Y[i].m;
        const Vec3 &H = d.Y[i].h, &P = d.hf[i];
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            const Motion &J = d.J[k], &dV = d.dV[k];
            const Vec3 x = ms * J.v + cross(J.w, H), y = (cross(J.w, P) + ms * dV.v) + cross(dV.w, H);
            for (int r = 0; r < 3; ++r) dcom_dq[r * nv + k] = x[r] / total, dvcom_dq[r * nv + k] = y[r] / total;
        }
    }
}

}  // namespace core
