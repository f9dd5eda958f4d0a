// Analytical derivatives of forward dynamics (aba_derivatives.hpp has the equations).
#include "aba_derivatives.hpp"

#include <algorithm>

#include "aba.hpp"
#include "checks.hpp"
#include "cpu_dispatch.hpp"
#include "minverse_passes.hpp"
#include "rnea_derivatives.hpp"

namespace core {

// oX = -Minv X and oY = -Minv Y (n x n, row-major): each entry the sum over k in increasing order, starting from
// +0, as the plain loop o -= Minv[i, k] X[k, j] makes it, so the bits are the textbook product's.  Two shortcuts
// keep those bits:
// - a block of 4 columns of R rows is summed in registers, X's and Y's rows read once for the R rows;
// - a k whose entries of X and Y in the block are all zero is left out: its terms are +-0, which change no sum
//   (a sum that starts at +0 is never -0).  dtau/dq and dtau/dv are zero between coordinates of different
//   branches, so on a tree with limbs most of the k go (Talos: about 60 %).
// X and Y are read up to 3 entries past their end (DerivativesData pads them); K: n ints of scratch.

template <int R>
ALWAYS_INLINE void minus_minv_times_rows(const double* Minv, const double* X, const double* Y, int n, int* K,
                                         double* oX, double* oY) {
    for (int j0 = 0; j0 < n; j0 += 4) {
        const int w = std::min(4, n - j0);
        int m = 0;
        for (int k = 0; k < n; ++k) {
            bool nonzero = false;
            for (int c = 0; c < w; ++c) nonzero |= X[k * n + j0 + c] != 0.0 || Y[k * n + j0 + c] != 0.0;
            if (nonzero) K[m++] = k;
        }
        for (int i = 0; i < n; i += R) {
            long row[R];  // rows i .. i + R - 1; past the last, the last again (computed twice, stored the same)
            for (int r = 0; r < R; ++r) row[r] = static_cast<long>(std::min(i + r, n - 1)) * n;
            double x[R][4] = {}, y[R][4] = {};
            for (int t = 0; t < m; ++t) {
                const int k = K[t];
                const double *bx = X + static_cast<long>(k) * n + j0, *by = Y + static_cast<long>(k) * n + j0;
                for (int r = 0; r < R; ++r) {
                    const double a = Minv[row[r] + k];
                    for (int c = 0; c < 4; ++c) x[r][c] -= a * bx[c], y[r][c] -= a * by[c];
                }
            }
            for (int r = 0; r < R; ++r)
                for (int c = 0; c < w; ++c) oX[row[r] + j0 + c] = x[r][c], oY[row[r] + j0 + c] = y[r][c];
        }
    }
}

// On x86-64 with GCC or Clang an AVX2 copy (4 rows at a time: 8 accumulators of 4 numbers) is compiled beside the
// portable one (2 rows: SSE2 has 16 registers of 2) and chosen by the CPU.  AVX2 does not include fused
// multiply-add (FMA is a feature of its own, not asked for), so both make the same products and differences: the
// same bits on every CPU.
#if HAVE_AVX2_CLONES
__attribute__((target("avx2"))) static void minus_minv_times_avx2(const double* Minv, const double* X,
                                                                  const double* Y, int n, int* K, double* oX,
                                                                  double* oY) {
    minus_minv_times_rows<4>(Minv, X, Y, n, K, oX, oY);
}
#endif

static void minus_minv_times(const double* Minv, const double* X, const double* Y, int n, int* K, double* oX,
                             double* oY) {
#if HAVE_AVX2_CLONES
    if (__builtin_cpu_supports("avx2")) return minus_minv_times_avx2(Minv, X, Y, n, K, oX, oY);
#endif
    minus_minv_times_rows<2>(Minv, X, Y, n, K, oX, oY);
}

int aba_derivatives(const Model& model, Data& data, DerivativesData& dd, const double* q, const double* v,
                    const double* tau, const Vec3& gravity, const double* f_ext, double* da_dq, double* da_dv,
                    double* Minv) {
    const int nb = model.nb, nv = model.nv;
    double* a = dd.qdd.data();
    int singular = aba(model, data, q, v, tau, gravity, f_ext, any_nonzero(v, nv), a);  // leaves X_i in data.X
    if (singular >= 0) return singular;
    // pass 1, forward: world poses, axes, velocities, accelerations at a, inertias and forces (the RNEA
    // derivatives' forward pass), and M^-1's inputs from them: the axes, each body's inertia, the subtree sizes
    derivatives_forward_pass(model, dd, data.X.data(), v, a, gravity, f_ext);
    for (int k = 0; k < nv; ++k) data.Sw[k] = dd.J[k];
    for (int i = 0; i < nb; ++i) data.IA[i] = to_matrix(dd.Y[i]), data.nsub[i] = model.nv_j[i];
    for (int i = nb - 1; i >= 0; --i)
        if (model.parents[i] >= 0) data.nsub[model.parents[i]] += data.nsub[i];
    // pass 2, backward: M^-1's rows with the articulated inertias; pass 3, backward: the RNEA derivatives' blocks
    // with the composite inertias; pass 4, forward: M^-1's columns
    singular = minverse_backward_pass(model, data, Minv);
    if (singular >= 0) return singular;
    rnea_derivatives_backward_pass(model, dd, dd.dtau_dq.data(), dd.dtau_dv.data());
    minverse_forward_pass(model, data, Minv);
    minus_minv_times(Minv, dd.dtau_dq.data(), dd.dtau_dv.data(), nv, dd.K.data(), da_dq, da_dv);
    return -1;
}

}  // namespace core
