// The torque sources' derivatives (derivatives.hpp has the formulas).
#include "derivatives.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "configuration.hpp"
#include "joints.hpp"
#include "operational_space_derivatives.hpp"

namespace core::control {

double so3_jinv_c(double p0, double p1, double p2) {
    const double phi2 = p0 * p0 + p1 * p1 + p2 * p2;
    if (phi2 < 1e-8) return 1.0 / 12.0 + phi2 / 720.0;
    const double phi = std::sqrt(phi2);
    return 1.0 / phi2 - (1.0 + std::cos(phi)) / (2.0 * phi * std::sin(phi));
}

namespace {

// dq[k:k+3, k:k+3] = -diag(kp) Jl(phi)^-1 with phi = e[k:k+3].
void rotation_error_block(const double* kp, const double* e, int k, int nv, double* dq) {
    const double p0 = e[k], p1 = e[k + 1], p2 = e[k + 2];
    const double c = so3_jinv_c(p0, p1, p2);
    const double n2 = p0 * p0 + p1 * p1 + p2 * p2;  // [phi]^2 = phi phi^T - |phi|^2 1
    const double P[3][3] = {{0.0, -p2, p1}, {p2, 0.0, -p0}, {-p1, p0, 0.0}};
    const double phi[3] = {p0, p1, p2};
    for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) {
            double jinv = -0.5 * P[r][s] + c * phi[r] * phi[s];
            if (r == s) jinv += 1.0 - c * n2;
            dq[(k + r) * nv + k + s] = -kp[k + r] * jinv;
        }
}

// Joint i's block of diag(kp) de/dq.
void pd_position_block(const Model& model, int i, const double* q, const double* e, const double* kp, double* dq) {
    const int k = model.v_idx[i], kq = model.q_idx[i], nv = model.nv;
    switch (model.jtype[i]) {
        case JOINT_SPHERICAL: rotation_error_block(kp, e, k, nv, dq); return;
        case JOINT_PLANAR: {
            const double n = std::sqrt(q[kq + 2] * q[kq + 2] + q[kq + 3] * q[kq + 3]);
            const double c = q[kq + 2] / n, s = q[kq + 3] / n;
            dq[k * nv + k] = -kp[k] * c, dq[k * nv + k + 1] = kp[k] * s;
            dq[(k + 1) * nv + k] = -kp[k + 1] * s, dq[(k + 1) * nv + k + 1] = -kp[k + 1] * c;
            dq[(k + 2) * nv + k + 2] = -kp[k + 2];
            return;
        }
        case JOINT_FREE: {
            const Quaternion quat = {q[kq + 3], q[kq + 4], q[kq + 5], q[kq + 6]};
            for (int s = 0; s < 3; ++s) {
                const Vec3 col = quaternion_rotate(quat, {s == 0 ? 1.0 : 0.0, s == 1 ? 1.0 : 0.0, s == 2 ? 1.0 : 0.0});
                for (int r = 0; r < 3; ++r) dq[(k + r) * nv + k + s] = -kp[k + r] * col[r];
            }
            rotation_error_block(kp, e, k + 3, nv, dq);
            return;
        }
        default: dq[k * nv + k] = -kp[k];
    }
}

bool pd_derivatives(const Model& model, const Source& src, SourceWorkspace& ws, const double* q, double* dq,
                    double* dv) {
    const int nv = model.nv;
    chart_difference(model, q, src.qref.data(), ws.e.data());
    for (int i = 0; i < model.nb; ++i) pd_position_block(model, i, q, ws.e.data(), src.gains.data(), dq);
    for (int k = 0; k < nv; ++k) dv[k * nv + k] = -src.gains[nv + k];
    return true;
}

}  // namespace

bool source_derivatives(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws, double t,
                        const double* q, const double* v, double* dq, double* dv) {
    const size_t n2 = static_cast<size_t>(model.nv) * model.nv;
    switch (src.kind) {
        case ZERO:
        case CONSTANT:
        case TABLE_LINEAR:
        case TABLE_ZOH:
            std::fill(dq, dq + n2, 0.0), std::fill(dv, dv + n2, 0.0);
            return true;
        case PD:
            std::fill(dq, dq + n2, 0.0), std::fill(dv, dv + n2, 0.0);
            return pd_derivatives(model, src, ws, q, dq, dv);
        case COMPUTED_TORQUE: return computed_torque_derivatives(model, src, ps, ws, t, q, v, dq, dv);
        case OPERATIONAL_SPACE: return operational_space_derivatives(model, src, ps, ws, t, q, v, dq, dv);
        default: return false;  // a Python callable: differenced by the caller
    }
}

bool source_derivatives_tangent(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws,
                                double t, const double* q, const double* v, double* dq, double* dv) {
    if (source_derivatives(model, src, ps, ws, t, q, v, dq, dv)) return true;
    const int nv = model.nv;
    std::vector<double> e(nv, 0.0), vt(v, v + nv), tp(nv), tm(nv), qt(model.nq), delta(nv);
    for (int k = 0; k < nv; ++k) {
        e[k] = 1.0;
        integrate(model, q, e.data(), FD_STEP, delta.data(), qt.data());
        source_torques(model, src, ps, ws, t, qt.data(), v, tp.data());
        integrate(model, q, e.data(), -FD_STEP, delta.data(), qt.data());
        source_torques(model, src, ps, ws, t, qt.data(), v, tm.data());
        e[k] = 0.0;
        for (int r = 0; r < nv; ++r) dq[r * nv + k] = (tp[r] - tm[r]) / (2 * FD_STEP);
    }
    for (int k = 0; k < nv; ++k) {
        const double h = FD_STEP * std::max(1.0, std::abs(v[k]));
        vt[k] = v[k] + h;
        source_torques(model, src, ps, ws, t, q, vt.data(), tp.data());
        vt[k] = v[k] - h;
        source_torques(model, src, ps, ws, t, q, vt.data(), tm.data());
        vt[k] = v[k];
        for (int r = 0; r < nv; ++r) dv[r * nv + k] = (tp[r] - tm[r]) / (2 * h);
    }
    return false;
}

}  // namespace core::control
