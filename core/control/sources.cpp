// The torque sources' evaluation (sources.hpp has the laws).
#include "sources.hpp"

#include <algorithm>
#include <cmath>

#include "configuration.hpp"
#include "interpolation.hpp"
#include "joints.hpp"
#include "operational_space.hpp"
#include "rnea.hpp"

namespace core::control {

SourceWorkspace::SourceWorkspace(const Model& model, int kind)
    : e(model.nv), qr(model.nv), vr(model.nv), ar(model.nv), pas(model.nv) {
    if (kind >= 0 && kind != COMPUTED_TORQUE && kind != OPERATIONAL_SPACE) return;
    const size_t nv = model.nv, n2 = nv * nv;
    data.resize(model);
    J.assign(6 * nv, 0.0), Minv.assign(n2, 0.0), JM.assign(6 * nv, 0.0), tp.assign(nv, 0.0), zero.assign(nv, 0.0);
    dd.resize(model);
    M.assign(n2, 0.0), DM.assign(n2, 0.0), pq.assign(nv, 0.0), pv.assign(nv, 0.0);
}

namespace {

// Linear or zero-order-hold interpolation of the rows of the table.
void table_torques(const Source& src, int nv, double t, double* tau) {
    const int N = src.samples();
    const double* tab = src.table.data();
    if (N == 1 || t <= src.times[0]) {
        std::copy(tab, tab + nv, tau);
    } else if (t >= src.times[N - 1]) {
        std::copy(tab + (N - 1) * nv, tab + N * nv, tau);
    } else {
        const int k = segment(src.times.data(), N, t);
        if (src.kind == TABLE_ZOH) {
            std::copy(tab + k * nv, tab + (k + 1) * nv, tau);
        } else {
            const double s = (t - src.times[k]) / (src.times[k + 1] - src.times[k]);
            for (int i = 0; i < nv; ++i) tau[i] = (1 - s) * tab[k * nv + i] + s * tab[(k + 1) * nv + i];
        }
    }
}

void pd_torques(const Model& model, const Source& src, SourceWorkspace& ws, const double* q, const double* v,
                double* tau) {
    const int nv = model.nv;
    // chart_difference(model, q, qref, e), its 1-dof joints' qref - q inline (a call per joint per evaluation: the
    // right-hand side's and every sample's)
    const double* qref = src.qref.data();
    double* e = ws.e.data();
    for (int i = 0; i < model.nb; ++i) {
        const int type = model.jtype[i];
        if (type == JOINT_REVOLUTE || type == JOINT_PRISMATIC) {
            const int kq = model.q_idx[i];
            e[model.v_idx[i]] = qref[kq] - q[kq];
        } else {
            joint_difference(model, i, q, qref, e);
        }
    }
    const double* g = src.gains.data();
    for (int i = 0; i < nv; ++i) tau[i] = g[i] * ws.e[i] + g[nv + i] * (g[2 * nv + i] - v[i]) + g[3 * nv + i];
}

void computed_torque(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws, double t,
                     const double* q, const double* v, double* tau) {
    const int nv = model.nv;
    reference_at(src.times.data(), src.samples(), src.table.data(), nv, t, ws.qr.data(), ws.vr.data(), ws.ar.data());
    const double* g = src.gains.data();
    for (int i = 0; i < nv; ++i) ws.ar[i] += g[nv + i] * (ws.vr[i] - v[i]) + g[i] * (ws.qr[i] - q[i]);
    rnea(model, ws.data, q, v, ws.ar.data(), ps.gravity, nullptr, true, true, tau);
    passive_torques(ps, q, v, nv, ws.pas.data());
    for (int i = 0; i < nv; ++i) tau[i] -= ws.pas[i];
}

}  // namespace

void source_torques(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws, double t,
                    const double* q, const double* v, double* tau) {
    const int nv = model.nv;
    switch (src.kind) {
        case ZERO: std::fill(tau, tau + nv, 0.0); return;
        case CONSTANT: std::copy(src.gains.data(), src.gains.data() + nv, tau); return;
        case TABLE_LINEAR:
        case TABLE_ZOH: table_torques(src, nv, t, tau); return;
        case PD: pd_torques(model, src, ws, q, v, tau); return;
        case COMPUTED_TORQUE: computed_torque(model, src, ps, ws, t, q, v, tau); return;
        case CALLABLE:
            if (!src.callback->torques(t, q, v, tau)) std::fill(tau, tau + nv, std::nan(""));
            return;
        case OPERATIONAL_SPACE: {
            passive_torques(ps, q, v, nv, ws.pas.data());
            operational_space_torques(model, src, ps.gravity, ws, t, q, v, ws.pas.data(), tau);
            return;
        }
        default: std::fill(tau, tau + nv, std::nan(""));
    }
}

}  // namespace core::control
