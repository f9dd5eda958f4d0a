// The closed loop's state derivatives: a = ABA(q, v, tau) with tau = tau_s(t, q, v) + tau_p(q, v), so by the chain
// rule
//     da/dq = da/dq|_tau + M^-1 (dtau_s/dq + dtau_p/dq),     da/dv = da/dv|_tau + M^-1 (dtau_s/dv + dtau_p/dv)
// with the ABA derivatives (aba_derivatives.hpp) and the source's (derivatives.hpp; differenced where it has none).
// The order of operations is the numba kernel's (dynamics/torque_derivatives.py, _closed_loop_kernel).
#include <vector>

#include "aba_derivatives.hpp"
#include "derivatives.hpp"

namespace core::control {

int closed_loop_derivatives(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws, double t,
                            const double* q, const double* v, double* da_dq, double* da_dv) {
    const int nv = model.nv;
    const size_t nn = static_cast<size_t>(nv) * nv;
    std::vector<double> dq(nn), dv(nn), tau(nv), pas(nv), pq(nv), pv(nv), Minv(nn);
    source_derivatives_tangent(model, src, ps, ws, t, q, v, dq.data(), dv.data());
    source_torques(model, src, ps, ws, t, q, v, tau.data());
    passive_torques(ps, q, v, nv, pas.data());
    passive_derivatives(ps, q, v, nv, pq.data(), pv.data());
    for (int k = 0; k < nv; ++k) {
        tau[k] += pas[k];
        dq[k * nv + k] += pq[k];
        dv[k * nv + k] += pv[k];
    }
    const int singular = aba_derivatives(model, ws.data, ws.dd, q, v, tau.data(), ps.gravity, nullptr, da_dq, da_dv,
                                         Minv.data());
    if (singular >= 0) return singular;
    for (int r = 0; r < nv; ++r)
        for (int c = 0; c < nv; ++c) {
            double sq = 0.0, sv = 0.0;
            for (int m = 0; m < nv; ++m) {
                sq += Minv[r * nv + m] * dq[m * nv + c];
                sv += Minv[r * nv + m] * dv[m * nv + c];
            }
            da_dq[r * nv + c] += sq;
            da_dv[r * nv + c] += sv;
        }
    return -1;
}

}  // namespace core::control
