// Analytical derivatives of forward dynamics (aba_derivatives.hpp has the equations).
#include "aba_derivatives.hpp"

#include <algorithm>

#include "aba.hpp"
#include "checks.hpp"
#include "minverse.hpp"
#include "rnea_derivatives.hpp"

namespace core {

// oX = -Minv X and oY = -Minv Y (n x n, row-major): each entry the sum over k in increasing order, starting from
// +0, as the plain loop o -= Minv[i, k] X[k, j] makes it, so the bits are the textbook product's.  Two shortcuts
// keep those bits:
// - a block of 4 columns of 2 rows is summed in registers, X's and Y's rows read once for both rows;
// - a k whose entries of X and Y in the block are all zero is left out: its terms are +-0, which change no sum
//   (a sum that starts at +0 is never -0).  dtau/dq and dtau/dv are zero between coordinates of different
//   branches, so on a tree with limbs most of the k go (Talos: about 60 %).
// X and Y are read up to 3 entries past their end (DerivativesData pads them); K: n ints of scratch.  On x86-64
// Linux an AVX2 copy is compiled beside the portable one and chosen at load time by the CPU: AVX2 has no fused
// multiply-add (that is FMA, not asked for), so both copies make the same products and differences, the same bits.
#if defined(__x86_64__) && defined(__linux__) && defined(__GNUC__)
__attribute__((target_clones("avx2", "default")))
#endif
static void minus_minv_times(const double* Minv, const double* X, const double* Y, int n, int* K, double* oX,
                             double* oY) {
    for (int j0 = 0; j0 < n; j0 += 4) {
        const int w = std::min(4, n - j0);
        int m = 0;
        for (int k = 0; k < n; ++k) {
            bool nonzero = false;
            for (int c = 0; c < w; ++c) nonzero |= X[k * n + j0 + c] != 0.0 || Y[k * n + j0 + c] != 0.0;
            if (nonzero) K[m++] = k;
        }
        for (int i = 0; i < n; i += 2) {
            const int i1 = std::min(i + 1, n - 1);  // n odd: the last row twice, stored once
            const double *r0 = Minv + static_cast<long>(i) * n, *r1 = Minv + static_cast<long>(i1) * n;
            double x0[4] = {0.0, 0.0, 0.0, 0.0}, x1[4] = {0.0, 0.0, 0.0, 0.0};
            double y0[4] = {0.0, 0.0, 0.0, 0.0}, y1[4] = {0.0, 0.0, 0.0, 0.0};
            for (int t = 0; t < m; ++t) {
                const int k = K[t];
                const double a0 = r0[k], a1 = r1[k];
                const double *bx = X + static_cast<long>(k) * n + j0, *by = Y + static_cast<long>(k) * n + j0;
                for (int c = 0; c < 4; ++c) {
                    x0[c] -= a0 * bx[c], x1[c] -= a1 * bx[c];
                    y0[c] -= a0 * by[c], y1[c] -= a1 * by[c];
                }
            }
            for (int c = 0; c < w; ++c) {
                oX[static_cast<long>(i) * n + j0 + c] = x0[c], oY[static_cast<long>(i) * n + j0 + c] = y0[c];
                oX[static_cast<long>(i1) * n + j0 + c] = x1[c], oY[static_cast<long>(i1) * n + j0 + c] = y1[c];
            }
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
    rnea_derivatives_at_poses(model, dd, data.oMi.data(), data.Sw.data(), v, a, gravity, f_ext, dd.dtau_dq.data(),
                              dd.dtau_dv.data());
    minus_minv_times(Minv, dd.dtau_dq.data(), dd.dtau_dv.data(), nv, dd.K.data(), da_dq, da_dv);
    return -1;
}

}  // namespace core
