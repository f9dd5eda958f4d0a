// Linear systems reduced to the velocities (second_order.hpp has the equations).
#include "second_order.hpp"

#include <algorithm>

#include "linalg.hpp"

namespace core::sim {

template <class T>
void ReducedSystem<T>::factor(const double* J, int n, const std::vector<int>& blocks, T mu) {
    const int nv = blocks.back();
    J_ = J, n_ = n, nv_ = nv, mu_ = mu, blocks_ = &blocks;
    const int nj = static_cast<int>(blocks.size()) - 1;
    off_.resize(nj + 1);
    off_[0] = 0;
    int mmax = 0;
    for (int j = 0; j < nj; ++j) {
        const int m = blocks[j + 1] - blocks[j];
        off_[j + 1] = off_[j] + m * m, mmax = std::max(mmax, m);
    }
    Binv_.assign(off_[nj], T(0)), G_.assign(off_[nj], T(0));
    S_.resize(static_cast<size_t>(nv) * nv), y_.resize(n), piv_.resize(nv);
    std::vector<T> B(static_cast<size_t>(mmax) * mmax);
    for (int j = 0; j < nj; ++j) {  // B^-1 and G = B^-1 Jcv, joint by joint
        const int k0 = blocks[j], m = blocks[j + 1] - k0;
        T *Bi = &Binv_[off_[j]], *Gj = &G_[off_[j]];
        for (int r = 0; r < m; ++r)
            for (int c = 0; c < m; ++c) B[r * m + c] = (r == c ? mu : T(0)) - J[(k0 + r) * n + k0 + c];
        lu_factor(B.data(), m, piv_.data());
        for (int c = 0; c < m; ++c) {  // column c of B^-1, then of G
            for (int r = 0; r < m; ++r) y_[r] = r == c ? T(1) : T(0);
            lu_solve(B.data(), m, piv_.data(), y_.data());
            for (int r = 0; r < m; ++r) Bi[r * m + c] = y_[r];
            for (int r = 0; r < m; ++r) y_[r] = J[(k0 + r) * n + nv + k0 + c];
            lu_solve(B.data(), m, piv_.data(), y_.data());
            for (int r = 0; r < m; ++r) Gj[r * m + c] = y_[r];
        }
    }
    for (int r = 0; r < nv; ++r) {  // S = mu I - Jav - Jad G
        const double* Ja = J + (nv + r) * n;
        for (int j = 0; j < nj; ++j) {
            const int k0 = blocks[j], m = blocks[j + 1] - k0;
            const T* Gj = &G_[off_[j]];
            for (int c = 0; c < m; ++c) {
                T s = (r == k0 + c ? mu : T(0)) - Ja[nv + k0 + c];
                for (int l = 0; l < m; ++l) s -= Ja[k0 + l] * Gj[l * m + c];
                S_[r * nv + k0 + c] = s;
            }
        }
    }
    lu_factor(S_.data(), nv, piv_.data());
}

template <class T>
void ReducedSystem<T>::solve(T* b) {
    const int n = n_, nv = nv_, nj = static_cast<int>(blocks_->size()) - 1;
    const std::vector<int>& blocks = *blocks_;
    const double* J = J_;
    T *yd = y_.data(), *xv = b + nv;
    for (int j = 0; j < nj; ++j) {  // y_d = B^-1 b_d
        const int k0 = blocks[j], m = blocks[j + 1] - k0;
        const T* Bi = &Binv_[off_[j]];
        for (int r = 0; r < m; ++r) {
            T s(0);
            for (int c = 0; c < m; ++c) s += Bi[r * m + c] * b[k0 + c];
            yd[k0 + r] = s;
        }
    }
    for (int r = 0; r < nv; ++r) {  // S x_v = b_v + Jad y_d
        const double* Ja = J + (nv + r) * n;
        T s = xv[r];
        for (int k = 0; k < nv; ++k) s += Ja[k] * yd[k];
        xv[r] = s;
    }
    lu_solve(S_.data(), nv, piv_.data(), xv);
    for (int j = 0; j < nj; ++j) {  // x_d = y_d + G x_v
        const int k0 = blocks[j], m = blocks[j + 1] - k0;
        const T* Gj = &G_[off_[j]];
        for (int r = 0; r < m; ++r) {
            T s = yd[k0 + r];
            for (int c = 0; c < m; ++c) s += Gj[r * m + c] * xv[k0 + c];
            b[k0 + r] = s;
        }
    }
    for (int i = 2 * nv; i < n; ++i) {  // x_w = (b_w + Jwd x_d + Jwv x_v) / mu
        const double* Jw = J + i * n;
        T s = b[i];
        for (int k = 0; k < 2 * nv; ++k) s += Jw[k] * b[k];
        b[i] = s / mu_;
    }
}

template class ReducedSystem<double>;
template class ReducedSystem<std::complex<double>>;

}  // namespace core::sim
