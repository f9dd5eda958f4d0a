// The solvers' shared numerical pieces (linalg.hpp).
#include "linalg.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace core::sim {

template <class T>
void envelope_lu_factor(T* A, int n, int* piv, int* env) {
    int *lo = env, *hi = env + n, *bot = env + 2 * n;
    for (int i = 0; i < n; ++i) lo[i] = hi[i] = bot[i] = i;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            if (A[i * n + j] != T(0)) {  // (NaN too)
                hi[i] = std::max(hi[i], j);
                bot[j] = std::max(bot[j], i);
            }
    for (int k = 0; k < n; ++k) {
        int m = k;
        double big = std::abs(A[k * n + k]);
        for (int i = k + 1; i <= bot[k]; ++i)
            if (std::abs(A[i * n + k]) > big) big = std::abs(A[i * n + k]), m = i;
        piv[k] = m;
        if (m != k) {
            for (int j = k; j <= hi[k]; ++j) bot[j] = std::max(bot[j], m);  // row k's entries move to row m
            for (int j = std::min(lo[k], lo[m]); j <= std::max(hi[k], hi[m]); ++j) std::swap(A[k * n + j], A[m * n + j]);
            std::swap(lo[k], lo[m]);
            std::swap(hi[k], hi[m]);
        }
        const T d = A[k * n + k];
        if (d == T(0)) continue;
        const int hk = hi[k];
        for (int i = k + 1; i <= bot[k]; ++i) {
            A[i * n + k] /= d;
            const T lik = A[i * n + k];
            if (lik != T(0)) {
                lo[i] = std::min(lo[i], k);
                hi[i] = std::max(hi[i], hk);
                for (int j = k + 1; j <= hk; ++j) {
                    A[i * n + j] -= lik * A[k * n + j];
                    bot[j] = std::max(bot[j], i);
                }
            }
        }
    }
}

template <class T>
static void permute(const int* piv, T* b, int n) {
    for (int k = 0; k < n; ++k)
        if (piv[k] != k) std::swap(b[k], b[piv[k]]);
}

template <class T>
void envelope_lu_solve(const T* LU, int n, const int* piv, const int* env, T* b) {
    const int *lo = env, *hi = env + n;
    permute(piv, b, n);
    for (int i = 0; i < n; ++i) {
        T s = b[i];
        for (int j = lo[i]; j < i; ++j) s -= LU[i * n + j] * b[j];
        b[i] = s;
    }
    for (int i = n - 1; i >= 0; --i) {
        T s = b[i];
        for (int j = i + 1; j <= hi[i]; ++j) s -= LU[i * n + j] * b[j];
        b[i] = s / LU[i * n + i];
    }
}

template void envelope_lu_factor<double>(double*, int, int*, int*);
template void envelope_lu_factor<std::complex<double>>(std::complex<double>*, int, int*, int*);
template void envelope_lu_solve<double>(const double*, int, const int*, const int*, double*);
template void envelope_lu_solve<std::complex<double>>(const std::complex<double>*, int, const int*, const int*,
                                                      std::complex<double>*);

template <class T>
void lu_factor(T* A, int n, int* piv) {
    for (int k = 0; k < n; ++k) {
        int m = k;
        double big = std::abs(A[k * n + k]);
        for (int i = k + 1; i < n; ++i)
            if (std::abs(A[i * n + k]) > big) big = std::abs(A[i * n + k]), m = i;
        piv[k] = m;
        if (m != k)
            for (int j = 0; j < n; ++j) std::swap(A[k * n + j], A[m * n + j]);
        const T d = A[k * n + k];
        if (d == T(0)) continue;
        for (int i = k + 1; i < n; ++i) {
            A[i * n + k] /= d;
            const T lik = A[i * n + k];
            if (lik != T(0))
                for (int j = k + 1; j < n; ++j) A[i * n + j] -= lik * A[k * n + j];
        }
    }
}

template <class T>
void lu_solve(const T* LU, int n, const int* piv, T* b) {
    permute(piv, b, n);
    for (int i = 0; i < n; ++i) {
        T s = b[i];
        for (int j = 0; j < i; ++j) s -= LU[i * n + j] * b[j];
        b[i] = s;
    }
    for (int i = n - 1; i >= 0; --i) {
        T s = b[i];
        for (int j = i + 1; j < n; ++j) s -= LU[i * n + j] * b[j];
        b[i] = s / LU[i * n + i];
    }
}

template void lu_factor<double>(double*, int, int*);
template void lu_factor<std::complex<double>>(std::complex<double>*, int, int*);
template void lu_solve<double>(const double*, int, const int*, double*);
template void lu_solve<std::complex<double>>(const std::complex<double>*, int, const int*, std::complex<double>*);

double scaled_rms(const double* e, const double* z0, const double* z1, const double* mag, int ne, double rtol,
                  double atol) {
    double s = 0.0;
    for (int i = 0; i < ne; ++i) {
        const double sc = atol + rtol * std::max(std::abs(z0[i]) + mag[i], std::abs(z1[i]) + mag[i]);
        const double x = e[i] / sc;
        s += x * x;
    }
    return std::sqrt(s / std::max(ne, 1));
}

double max_abs(const double* x, int ne) {
    double m = 0.0;
    for (int i = 0; i < ne; ++i) {
        const double a = std::abs(x[i]);
        if (!(a <= m)) m = a;  // also propagates NaN
    }
    return m;
}

Status state_status(const double* z, int n, int nc, int nvel, double blowup) {
    for (int i = 0; i < n; ++i)
        if (!std::isfinite(z[i])) return NONFINITE;
    for (int i = nc; i < nc + nvel; ++i)
        if (std::abs(z[i]) > blowup) return BLOWUP;
    return OK;
}

double initial_step(Problem& p, double t, const double* z, const double* f0, int n, int order, double rtol, double atol,
                    const double* mag, int ne, double t_end, Stats& st) {
    const double span = t_end - t;
    if (span <= 0) return 0.0;
    double d0 = 0.0, d1 = 0.0;
    for (int i = 0; i < ne; ++i) {
        const double sc = atol + rtol * (std::abs(z[i]) + mag[i]);
        d0 += (z[i] / sc) * (z[i] / sc);
        d1 += (f0[i] / sc) * (f0[i] / sc);
    }
    d0 = std::sqrt(d0 / std::max(ne, 1));
    d1 = std::sqrt(d1 / std::max(ne, 1));
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = std::min(h0, span);
    std::vector<double> z1(n), f1(n);
    for (int i = 0; i < n; ++i) z1[i] = z[i] + h0 * f0[i];
    p.rhs(t + h0, z1.data(), f1.data());
    st.rhs_evals += 1;
    double d2 = 0.0;
    for (int i = 0; i < ne; ++i) {
        const double sc = atol + rtol * (std::abs(z[i]) + mag[i]);
        d2 += ((f1[i] - f0[i]) / sc) * ((f1[i] - f0[i]) / sc);
    }
    d2 = std::sqrt(d2 / std::max(ne, 1)) / h0;
    if (!std::isfinite(d2)) return h0 * 1e-3;
    const double h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? std::max(1e-6, h0 * 1e-3)
                                                   : std::pow(0.01 / std::max(d1, d2), 1.0 / (order + 1));
    return std::min(std::min(100 * h0, h1), span);
}

void fd_jacobian(Problem& p, double t, const double* z, const double* f0, const double* mag, int n, int ne, double* J,
                 Stats& st) {
    std::vector<double> zt(z, z + n), ft(n);
    for (int c = 0; c < n; ++c) {
        if (c >= ne) {
            for (int r = 0; r < n; ++r) J[r * n + c] = 0.0;
            continue;
        }
        double d = 1.4901161193847656e-08 * std::max(1.0, std::abs(z[c]) + mag[c]);
        zt[c] = z[c] + d;
        d = zt[c] - z[c];  // the step actually representable
        p.rhs(t, zt.data(), ft.data());
        zt[c] = z[c];
        for (int r = 0; r < n; ++r) J[r * n + c] = (ft[r] - f0[r]) / d;
    }
    st.rhs_evals += ne;
    st.jacobian_evals += 1;
}

void problem_jacobian(Problem& p, double t, const double* z, const double* f0, const double* mag, int n, int ne,
                      double* J, Stats& st) {
    if (!p.jacobian(t, z, f0, mag, ne, J, st)) fd_jacobian(p, t, z, f0, mag, n, ne, J, st);
}

double spectral_radius(const double* J, int n, int ne) {
    const int m = ne;
    thread_local std::vector<int> first, last;  // each row's first and last nonzero column: the products skip zeros
    thread_local std::vector<double> x, y;      // (the thread's: a probe per run allocates nothing once warm)
    first.resize(m), last.resize(m), x.resize(m), y.resize(m);
    for (int r = 0; r < m; ++r) {
        first[r] = m, last[r] = -1;
        for (int c = 0; c < m; ++c)
            if (J[r * n + c] != 0) first[r] = std::min(first[r], c), last[r] = c;
    }
    double nrm = 0.0;
    for (int i = 0; i < m; ++i) {
        x[i] = 1.0 + 0.1 * ((i * 7919) % 13);  // a fixed, generic start vector
        nrm += x[i] * x[i];
    }
    nrm = std::sqrt(nrm);
    if (nrm == 0) return 0.0;
    for (int i = 0; i < m; ++i) x[i] /= nrm;
    double logsum = 0.0;
    int cnt = 0;
    for (int it = 0; it < 30; ++it) {
        nrm = 0.0;
        for (int r = 0; r < m; ++r) {
            double s = 0.0;
            for (int c = first[r]; c <= last[r]; ++c) s += J[r * n + c] * x[c];
            y[r] = s;
            nrm += s * s;
        }
        nrm = std::sqrt(nrm);
        if (nrm == 0.0 || !std::isfinite(nrm)) return nrm == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
        if (it >= 15) logsum += std::log(nrm), ++cnt;
        for (int r = 0; r < m; ++r) x[r] = y[r] / nrm;
    }
    return std::exp(logsum / cnt);
}

double jacobian_spectral_radius(Problem& p, double t, const double* z, const double* f0, int n, int ne) {
    thread_local std::vector<double> J, mag;  // (the thread's scratch, as spectral_radius's)
    J.resize(static_cast<size_t>(n) * n), mag.assign(n, 0.0);
    Stats scratch;
    problem_jacobian(p, t, z, f0, mag.data(), n, ne, J.data(), scratch);  // analytical where the problem has one
    return spectral_radius(J.data(), n, ne);
}

Stats::Stats()
    : t(std::nan("")), h(std::nan("")), stiff_t(std::nan("")), h_rho(std::nan("")), rho0(std::nan("")) {}

}  // namespace core::sim
