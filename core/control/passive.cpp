// The passive joint torques and their derivatives (passive.hpp has the laws).
#include "passive.hpp"

#include <algorithm>
#include <cmath>

namespace core::control {

void passive_torques(const Passive& ps, const double* q, const double* v, int nv, double* out) {
    for (int k = 0; k < nv; ++k) {
        double tq = -ps.damping[k] * v[k];
        if (ps.friction[k] != 0.0) tq -= ps.friction[k] * std::tanh(v[k] / ps.friction_eps);
        if (ps.limits && ps.qpos[k] >= 0) {
            const double x = q[ps.qpos[k]];
            if (x < ps.lower[k]) {
                const double pen = ps.lower[k] - x;
                tq += std::max(0.0, ps.k_limit * pen - ps.b_limit * pen * v[k]);
            } else if (x > ps.upper[k]) {
                const double pen = x - ps.upper[k];
                tq -= std::max(0.0, ps.k_limit * pen + ps.b_limit * pen * v[k]);
            }
        }
        out[k] = tq;
    }
}

// -b, -mu (1 - tanh^2(v/eps))/eps, and the Hunt-Crossley springs' -(k +- b v), -b pen while they push.
void passive_derivatives(const Passive& ps, const double* q, const double* v, int nv, double* dq, double* dv) {
    for (int k = 0; k < nv; ++k) {
        dq[k] = 0.0;
        dv[k] = -ps.damping[k];
        if (ps.friction[k] != 0.0) {
            const double th = std::tanh(v[k] / ps.friction_eps);
            dv[k] -= ps.friction[k] * (1.0 - th * th) / ps.friction_eps;
        }
        if (ps.limits && ps.qpos[k] >= 0) {
            const double x = q[ps.qpos[k]];
            if (x < ps.lower[k]) {
                const double pen = ps.lower[k] - x;
                if (ps.k_limit * pen - ps.b_limit * pen * v[k] > 0.0) {
                    dq[k] = -(ps.k_limit - ps.b_limit * v[k]);
                    dv[k] -= ps.b_limit * pen;
                }
            } else if (x > ps.upper[k]) {
                const double pen = x - ps.upper[k];
                if (ps.k_limit * pen + ps.b_limit * pen * v[k] > 0.0) {
                    dq[k] = -(ps.k_limit + ps.b_limit * v[k]);
                    dv[k] -= ps.b_limit * pen;
                }
            }
        }
    }
}

}  // namespace core::control
