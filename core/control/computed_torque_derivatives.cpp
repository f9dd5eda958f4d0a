// The computed torque's state derivatives (derivatives.hpp has the formulas):
//     tau = RNEA(q, v, a*) - tau_passive(q, v),   a* = a_ref + kd (v_ref - v) + kp (q_ref - q)
//     dtau/dq = dRNEA/dq (q, v, a*) - M diag(kp) - dtau_passive/dq
//     dtau/dv = dRNEA/dv (q, v, a*) - M diag(kd) - dtau_passive/dv
// on a model of 1-dof joints (nq = nv, the source's own requirement), in the order of operations of the numba kernel
// it replaces (dynamics/control/derivatives.py, _computed_torque_derivatives), so the same bits.
#include "derivatives.hpp"
#include "interpolation.hpp"
#include "rnea_derivatives.hpp"

namespace core::control {

bool computed_torque_derivatives(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws,
                                 double t, const double* q, const double* v, double* dq, double* dv) {
    const int nv = model.nv;
    const double *kp = src.gains.data(), *kd = src.gains.data() + nv;
    double *qr = ws.qr.data(), *vr = ws.vr.data(), *ar = ws.ar.data(), *M = ws.M.data();
    reference_at(src.times.data(), src.samples(), src.table.data(), nv, t, qr, vr, ar);
    for (int i = 0; i < nv; ++i) ar[i] += kd[i] * (vr[i] - v[i]) + kp[i] * (qr[i] - q[i]);  // a*
    rnea_derivatives(model, ws.dd, q, v, ar, ps.gravity, nullptr, dq, dv, M);
    passive_derivatives(ps, q, v, nv, ws.pq.data(), ws.pv.data());
    for (int r = 0; r < nv; ++r) {
        for (int c = 0; c < nv; ++c) {
            dq[r * nv + c] -= M[r * nv + c] * kp[c];
            dv[r * nv + c] -= M[r * nv + c] * kd[c];
        }
        dq[r * nv + r] -= ws.pq[r];
        dv[r * nv + r] -= ws.pv[r];
    }
    return true;
}

}  // namespace core::control
