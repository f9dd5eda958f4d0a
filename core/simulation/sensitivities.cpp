// The variational equations of a simulation (sensitivities.hpp).
#include "sensitivities.hpp"

#include <algorithm>
#include <cmath>

#include "configuration.hpp"
#include "linalg.hpp"

namespace core::sim {

namespace {
constexpr double FD_STEP = 6e-6;
}

SensitivityProblem::SensitivityProblem(RobotProblem& inner, bool x0, std::vector<int> params, double* out_S,
                                       double* Sf)
    : inner_(inner), model_(inner.model()), nv_(model_.nv), n2_(2 * model_.nv), nquad_(inner.nquad()),
      nx_(x0 ? 2 * model_.nv : 0), ncol_(nx_ + static_cast<int>(params.size() / 3)), params_(std::move(params)),
      out_S_(out_S), Sf_(Sf), zi_(n2_ + nquad_), fi_(zi_.size()), fp_(zi_.size()), fm_(zi_.size()),
      magi_(zi_.size()), J_(zi_.size() * zi_.size()), B_(static_cast<size_t>(n2_) * (params_.size() / 3)),
      C_(static_cast<size_t>(nv_) * nv_), col_(nv_), delta_(nv_), piv_(nv_) {
    std::fill(Sf_, Sf_ + static_cast<size_t>(n2_) * ncol_, 0.0);
    for (int k = 0; k < nx_; ++k) Sf_[k * ncol_ + k] = 1.0;
}

void SensitivityProblem::initial_state(const double* v0, double* z) const {
    std::fill(z, z + size(), 0.0);
    std::copy(v0, v0 + nv_, z + nv_);
    std::vector<double> C(static_cast<size_t>(nv_) * nv_), zero(nv_, 0.0);
    const bool free = model_.nq != nv_;
    if (free) chart_matrix(inner_.base(), zero.data(), C.data());
    for (int c = 0; c < nx_; ++c) {  // S0 = [C0 | 0] column by column: C0 on the q0 columns' q-rows
        double* col = z + n2_ + c * n2_;
        if (c < nv_ && free)
            for (int r = 0; r < nv_; ++r) col[r] = C[r * nv_ + c];
        else
            col[c] = 1.0;
    }
}

void SensitivityProblem::final(const double* z, double* S) const {
    if (model_.nq != nv_) {
        std::copy(Sf_, Sf_ + static_cast<size_t>(n2_) * ncol_, S);
        return;
    }
    for (int c = 0; c < ncol_; ++c)
        for (int r = 0; r < n2_; ++r) S[r * ncol_ + c] = z[n2_ + c * n2_ + r];
}

// C = d delta / d e for the tangent displacement e at q = retract(base, delta): column k is the chart rate of e_k.
void SensitivityProblem::chart_matrix(const double* q, const double* delta, double* C) const {
    std::vector<double> e(nv_, 0.0), col(nv_);
    for (int k = 0; k < nv_; ++k) {
        e[k] = 1.0;
        chart_rate(model_, q, delta, e.data(), col.data());
        e[k] = 0.0;
        for (int r = 0; r < nv_; ++r) C[r * nv_ + k] = col[r];
    }
}

// S[:, c] = [C^-1 S_q, S_v] of the c-th column of S stored in z from offset o (C is LU-factored here).
void SensitivityProblem::rows_to_tangent(double* C, const double* z, int o, double* S) {
    lu_factor(C, nv_, piv_.data());
    for (int c = 0; c < ncol_; ++c) {
        const int b = o + c * n2_;
        for (int r = 0; r < nv_; ++r) col_[r] = z[b + r];
        lu_solve(C, nv_, piv_.data(), col_.data());
        for (int r = 0; r < nv_; ++r) S[r * ncol_ + c] = col_[r];
        for (int r = nv_; r < n2_; ++r) S[r * ncol_ + c] = z[b + r];
    }
}

// The inner state of z: its first 2 nv components and the quadratures at its end.
void SensitivityProblem::split(const double* z) {
    const int N = size();
    std::copy(z, z + n2_, zi_.begin());
    for (int r = 0; r < nquad_; ++r) zi_[n2_ + r] = z[N - nquad_ + r];
}

void SensitivityProblem::join(const double* fi, double* dz) const {
    const int N = size();
    std::copy(fi, fi + n2_, dz);
    for (int r = 0; r < nquad_; ++r) dz[N - nquad_ + r] = fi[n2_ + r];
}

double* SensitivityProblem::parameter(int j) {
    control::Source& src = inner_.source();
    const int place = params_[3 * j], row = params_[3 * j + 1], col = params_[3 * j + 2];
    if (place == GAINS) return &src.gains[static_cast<size_t>(row) * nv_ + col];
    if (place == QREF) return &src.qref[col];
    return &src.table[static_cast<size_t>(row) * src.table_cols + col];
}

// B = d(q', v')/dp at (t, zi): the inner right-hand side differenced in each parameter (restored bit for bit).
void SensitivityProblem::parameter_derivatives(double t) {
    const int P = static_cast<int>(params_.size() / 3);
    for (int j = 0; j < P; ++j) {
        double* x = parameter(j);
        const double x0 = *x, h = FD_STEP * std::max(1.0, std::abs(x0));
        *x = x0 + h;
        inner_.rhs(t, zi_.data(), fp_.data());
        *x = x0 - h;
        inner_.rhs(t, zi_.data(), fm_.data());
        *x = x0;
        for (int r = 0; r < n2_; ++r) B_[r * P + j] = (fp_[r] - fm_[r]) / (2 * h);
    }
}

// dz = [f(t, x), J S + [0 | df/dp], powers].
void SensitivityProblem::rhs(double t, const double* z, double* dz) {
    split(z);
    inner_.rhs(t, zi_.data(), fi_.data());
    join(fi_.data(), dz);
    const int ni = static_cast<int>(zi_.size()), P = static_cast<int>(params_.size() / 3);
    problem_jacobian(inner_, t, zi_.data(), fi_.data(), magi_.data(), ni, n2_, J_.data(), jst_);
    if (P > 0) parameter_derivatives(t);
    for (int c = 0; c < ncol_; ++c) {
        const int o = n2_ + c * n2_;
        for (int r = 0; r < n2_; ++r) {
            double s = c >= nx_ ? B_[r * P + (c - nx_)] : 0.0;
            for (int k = 0; k < n2_; ++k) s += J_[r * ni + k] * z[o + k];
            dz[o + r] = s;
        }
    }
}

// Radau's Newton matrix of the augmented system: diag(Jx, ..., Jx) and the quadratures' rows.
bool SensitivityProblem::jacobian(double t, const double* z, const double*, const double*, int, double* J, Stats& st) {
    split(z);
    const int ni = static_cast<int>(zi_.size()), N = size();
    if (!inner_.jacobian(t, zi_.data(), nullptr, magi_.data(), n2_, J_.data(), st)) {  // differenced: f first
        inner_.rhs(t, zi_.data(), fi_.data());
        fd_jacobian(inner_, t, zi_.data(), fi_.data(), magi_.data(), ni, n2_, J_.data(), st);
    }
    std::fill(J, J + static_cast<size_t>(N) * N, 0.0);
    for (int b = 0; b <= ncol_; ++b) {
        const int o = b * n2_;
        for (int r = 0; r < n2_; ++r)
            for (int k = 0; k < n2_; ++k) J[static_cast<size_t>(o + r) * N + o + k] = J_[r * ni + k];
    }
    for (int r = 0; r < nquad_; ++r)
        for (int k = 0; k < n2_; ++k) J[static_cast<size_t>(N - nquad_ + r) * N + k] = J_[(n2_ + r) * ni + k];
    return true;
}

// The inner problem's re-centring; S's magnitudes are zero.  With 1-dof joints the chart moves by a shift: S is
// unchanged.  Otherwise S's q-rows are carried to the new chart, S <- C(q1, 0) C(q1, delta1)^-1 S, the tangent S kept
// in Sf, and dz evaluated again in the new chart.
void SensitivityProblem::rebase(double t, double* z, double* dz, double* mag) {
    split(z);
    std::copy(zi_.begin(), zi_.begin() + nv_, delta_.begin());
    inner_.rebase(t, zi_.data(), fi_.data(), magi_.data());
    std::copy(zi_.begin(), zi_.begin() + n2_, z);
    std::copy(magi_.begin(), magi_.begin() + n2_, mag);
    join(fi_.data(), dz);
    std::fill(mag + n2_, mag + size(), 0.0);
    if (model_.nq == nv_) return;
    chart_matrix(inner_.base(), delta_.data(), C_.data());  // C(q1, delta1): q1 is the new base
    rows_to_tangent(C_.data(), z, n2_, Sf_);
    std::fill(delta_.begin(), delta_.end(), 0.0);
    chart_matrix(inner_.base(), delta_.data(), C_.data());  // C(q1, 0)
    for (int c = 0; c < ncol_; ++c) {
        const int o = n2_ + c * n2_;
        for (int r = 0; r < nv_; ++r) {
            double s = 0.0;
            for (int k = 0; k < nv_; ++k) s += C_[r * nv_ + k] * Sf_[k * ncol_ + c];
            z[o + r] = s;
        }
    }
    rhs(t, z, dz);
}

// Sample j of the inner problem and S with tangent q-rows (C(q, delta)^-1 on the chart rows).
void SensitivityProblem::emit(int64_t j, double t, const double* z) {
    split(z);
    inner_.emit(j, t, zi_.data());
    if (!out_S_) return;
    double* S = out_S_ + static_cast<size_t>(j) * n2_ * ncol_;
    if (model_.nq == nv_) {
        for (int c = 0; c < ncol_; ++c)
            for (int r = 0; r < n2_; ++r) S[r * ncol_ + c] = z[n2_ + c * n2_ + r];
        return;
    }
    std::vector<double> q(model_.nq);
    retract(model_, inner_.base(), z, q.data());  // the sample's configuration
    chart_matrix(q.data(), z, C_.data());
    rows_to_tangent(C_.data(), z, n2_, S);
}

}  // namespace core::sim
