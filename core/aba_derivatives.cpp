// Analytical derivatives of forward dynamics (aba_derivatives.hpp has the equations).
#include "aba_derivatives.hpp"

#include <algorithm>

#include "aba.hpp"
#include "checks.hpp"
#include "minverse.hpp"
#include "rnea_derivatives.hpp"

namespace core {

// out = -A B for n x n row-major matrices; each entry sums over k in increasing order.
static void neg_product(const double* A, const double* B, int n, double* out) {
    std::fill(out, out + static_cast<long>(n) * n, 0.0);
    for (int i = 0; i < n; ++i) {
        double* o = out + static_cast<long>(i) * n;
        for (int k = 0; k < n; ++k) {
            const double x = A[static_cast<long>(i) * n + k];
            const double* b = B + static_cast<long>(k) * n;
            for (int j = 0; j < n; ++j) o[j] -= x * b[j];
        }
    }
}

int aba_derivatives(const Model& model, Data& data, DerivativesData& dd, const double* q, const double* v,
                    const double* tau, const Vec3& gravity, const double* f_ext, double* da_dq, double* da_dv,
                    double* Minv) {
    const int nv = model.nv;
    double* a = dd.qdd.data();
    int singular = aba(model, data, q, v, tau, gravity, f_ext, any_nonzero(v, nv), a);
    if (singular < 0) singular = inverse_mass_matrix(model, data, q, Minv);
    if (singular >= 0) return singular;
    rnea_derivatives(model, dd, q, v, a, gravity, f_ext, dd.dtau_dq.data(), dd.dtau_dv.data(), dd.M.data());
    neg_product(Minv, dd.dtau_dq.data(), nv, da_dq);
    neg_product(Minv, dd.dtau_dv.data(), nv, da_dv);
    return -1;
}

}  // namespace core
