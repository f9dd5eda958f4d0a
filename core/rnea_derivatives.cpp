// Analytical derivatives of inverse dynamics (rnea_derivatives.hpp has the equations).
#include "rnea_derivatives.hpp"

#include <algorithm>

#include "cpu_dispatch.hpp"
#include "joints.hpp"

namespace core {

namespace {

// B of dY = [[B, 0], [-2 [hf]x, 0]] for the inertia Y and the motion ov = (w, vl), (hn, hf) = Y ov:
// B = [w] Io - Io [w] - ([vl][h] + [h][vl]) - [hn], with [vl][h] + [h][vl] = h vl^T + vl h^T - 2 (vl . h) 1.
Mat3 velocity_variation(const Inertia& Y, const Motion& ov, const Vec3& hn) {
    const Mat3 W = skew(ov.w), WI = W * Y.Io, IW = Y.Io * W;
    const Vec3 &h = Y.h, &vl = ov.v;
    const double s = 2.0 * dot(vl, h);
    return {{WI[0] - IW[0] - 2.0 * h.x * vl.x + s, WI[1] - IW[1] - h.x * vl.y - vl.x * h.y + hn.z,
             WI[2] - IW[2] - h.x * vl.z - vl.x * h.z - hn.y, WI[3] - IW[3] - h.y * vl.x - vl.y * h.x - hn.z,
             WI[4] - IW[4] - 2.0 * h.y * vl.y + s, WI[5] - IW[5] - h.y * vl.z - vl.y * h.z + hn.x,
             WI[6] - IW[6] - h.z * vl.x - vl.z * h.x + hn.y, WI[7] - IW[7] - h.z * vl.y - vl.z * h.y - hn.x,
             WI[8] - IW[8] - 2.0 * h.z * vl.z + s}};
}

// dY m = (B w, -2 hf x w) for m = (w, .): dY's right column is zero, so only the angular half of m acts.
Force dY_times(const Mat3& B, const Vec3& hf, const Vec3& w) { return {rot(B, w), -2.0 * cross(hf, w)}; }

// Body i's step of the forward pass, its world pose d.oM[i] and axes d.J[k] written (its parent's step done).
inline void forward_body(const Model& model, DerivativesData& d, int i, const double* v, const double* a,
                         const Motion& a0, const double* f_ext) {
    const int par = model.parents[i], k0 = model.v_idx[i], k1 = k0 + model.nv_j[i];
    const Transform& oM = d.oM[i];
    const Motion vp = par < 0 ? Motion{} : d.ov[par], ap = par < 0 ? a0 : d.oa[par];
    Motion vJ, aJ;
    for (int k = k0; k < k1; ++k) {
        vJ = vJ + v[k] * d.J[k];
        aJ = aJ + a[k] * d.J[k];
    }
    const Motion ov = d.ov[i] = vp + vJ;
    for (int k = k0; k < k1; ++k) {
        d.dV[k] = cross(vp, d.J[k]);
        d.dAv[k] = cross(ov, d.J[k]) + d.dV[k];
        d.dAq[k] = cross(ap, d.J[k]) + cross(vp, d.dV[k]);
    }
    const Motion oa = d.oa[i] = (ap + aJ) + cross(ov, vJ);
    const Inertia& Y = d.Y[i] = inertia_to_parent(oM, model.I[i]);
    const Force h = Y * ov;
    Force b = cross(ov, h);
    if (f_ext) b = b - force_to_parent(oM, force_from_api(f_ext + 6 * i));
    d.F[i] = Y * oa + b;
    d.B[i] = velocity_variation(Y, ov, h.n);
    d.hf[i] = h.f;
}

// The backward pass: with_M = false leaves M alone (the ABA derivatives do not need it).
template <bool with_M>
inline void backward_pass(const Model& model, DerivativesData& d, double* dtau_dq, double* dtau_dv, double* M) {
    const int nv = model.nv;
    for (int i = model.nb - 1; i >= 0; --i) {  // backward: i's rows and columns against itself and its ancestors
        const int par = model.parents[i], k0 = model.v_idx[i], k1 = k0 + model.nv_j[i];
        const Inertia& Y = d.Y[i];
        const Mat3& B = d.B[i];
        const Vec3& hf = d.hf[i];
        const Force& f = d.F[i];
        for (int k = k0; k < k1; ++k) {
            d.Fa[k] = Y * d.J[k];
            d.Fv[k] = Y * d.dAv[k] + dY_times(B, hf, d.J[k].w);
            d.Fq[k] = Y * d.dAq[k] + dY_times(B, hf, d.dV[k].w);
        }
        for (int r = k0; r < k1; ++r)
            for (int k = k0; k < k1; ++k) {
                if (with_M) M[r * nv + k] = dot(d.J[r], d.Fa[k]);
                dtau_dv[r * nv + k] = dot(d.J[r], d.Fv[k]);
                dtau_dq[r * nv + k] = dot(d.J[r], d.Fq[k]);
            }
        for (int k = k0; k < k1; ++k) {
            d.Fq[k] = d.Fq[k] + cross(d.J[k], f);
            d.lv[k] = rotT(B, d.J[k].w) + 2.0 * cross(hf, d.J[k].v);
        }
        for (int anc = par; anc >= 0; anc = model.parents[anc])
            for (int c = model.v_idx[anc]; c < model.v_idx[anc] + model.nv_j[anc]; ++c)
                for (int k = k0; k < k1; ++k) {
                    if (with_M) {
                        const double x = dot(d.J[c], d.Fa[k]);
                        M[c * nv + k] = x;
                        M[k * nv + c] = x;
                    }
                    dtau_dv[c * nv + k] = dot(d.J[c], d.Fv[k]);
                    dtau_dq[c * nv + k] = dot(d.J[c], d.Fq[k]);
                    dtau_dv[k * nv + c] = dot(d.dAv[c], d.Fa[k]) + dot(d.lv[k], d.J[c].w);
                    dtau_dq[k * nv + c] = dot(d.dAq[c], d.Fa[k]) + dot(d.lv[k], d.dV[c].w);
                }
        if (par < 0) continue;
        Inertia& Yp = d.Y[par];  // the subtree's Y, dY and F into the parent's
        Yp.m += Y.m, Yp.h = Yp.h + Y.h, Yp.Io = Yp.Io + Y.Io;
        d.B[par] = d.B[par] + B, d.hf[par] = d.hf[par] + hf, d.F[par] = d.F[par] + f;
    }
}

}  // namespace

void derivatives_forward_pass(const Model& model, DerivativesData& d, const double* q, const double* v,
                              const double* a, const Vec3& gravity, const double* f_ext) {
    const Motion a0 = {{}, -gravity};  // the world accelerates up
    for (int i = 0; i < model.nb; ++i) {  // poses and axes, then velocities, accelerations, their variations, f_i
        const int par = model.parents[i];
        const Transform X = joint_transform(model, i, q);
        const Transform& oM = d.oM[i] = par < 0 ? X : compose(d.oM[par], X);
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k)
            d.J[k] = motion_to_parent(oM, model.S[k]);
        forward_body(model, d, i, v, a, a0, f_ext);
    }
}

void rnea_derivatives(const Model& model, DerivativesData& d, const double* q, const double* v, const double* a,
                      const Vec3& gravity, const double* f_ext, double* dtau_dq, double* dtau_dv, double* M) {
    const long nn = static_cast<long>(model.nv) * model.nv;
    std::fill(dtau_dq, dtau_dq + nn, 0.0), std::fill(dtau_dv, dtau_dv + nn, 0.0), std::fill(M, M + nn, 0.0);
    derivatives_forward_pass(model, d, q, v, a, gravity, f_ext);
    backward_pass<true>(model, d, dtau_dq, dtau_dv, M);
}

AVX2_CLONE FLATTEN void derivatives_forward_pass(const Model& model, DerivativesData& d, const Transform* X,
                                                const double* v, const double* a, const Vec3& gravity,
                                                const double* f_ext) {
    const Motion a0 = {{}, -gravity};
    for (int i = 0; i < model.nb; ++i) {
        const int par = model.parents[i];
        const Transform& oM = d.oM[i] = par < 0 ? X[i] : compose(d.oM[par], X[i]);
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k)
            d.J[k] = motion_to_parent(oM, model.S[k]);
        forward_body(model, d, i, v, a, a0, f_ext);
    }
}

AVX2_CLONE FLATTEN void rnea_derivatives_backward_pass(const Model& model, DerivativesData& d, double* dtau_dq,
                                                      double* dtau_dv) {
    const long nn = static_cast<long>(model.nv) * model.nv;
    std::fill(dtau_dq, dtau_dq + nn, 0.0), std::fill(dtau_dv, dtau_dv + nn, 0.0);
    backward_pass<false>(model, d, dtau_dq, dtau_dv, nullptr);
}

}  // namespace core
