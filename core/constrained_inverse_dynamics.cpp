// Constrained inverse dynamics (constrained_inverse_dynamics.hpp has the equations).
#include "constrained_inverse_dynamics.hpp"

#include <algorithm>
#include <cmath>

#include "rnea.hpp"

namespace core {

void ConstrainedInverseData::resize(const Model& model, const Constraints& con) {
    const size_t nv = model.nv;
    cd.resize(model, con);
    f.resize(nv), Pf.resize(nv), y.resize(nv), c.resize(nv), U.resize(nv * nv);
    W.resize(nv * nv), C.resize(nv * nv), CC.resize(nv * nv), kept.resize(nv), act.resize(nv);
}

namespace {

double dot_n(const double* x, const double* y, int n) {
    double s = 0.0;
    for (int k = 0; k < n; ++k) s += x[k] * y[k];
    return s;
}

double norm_n(const double* x, int n) { return std::sqrt(dot_n(x, x, n)); }

// Whether J a + gamma = 0 within 1e-8 of the size of its terms, row by row.
bool satisfies_constraints(const double* J, const double* gamma, const double* a, int m, int nv) {
    for (int r = 0; r < m; ++r) {
        double x = gamma[r], s = std::abs(gamma[r]);
        for (int c = 0; c < nv; ++c) {
            x += J[r * nv + c] * a[c];
            s += std::abs(J[r * nv + c] * a[c]);
        }
        if (std::abs(x) > 1e-8 * std::max(s, 1e-3)) return false;
    }
    return true;
}

// x (n) minus its components along the rank rows of B (orthonormal, n each), twice ("twice is enough"); coef
// (rank), when given, receives the components.
void orthogonalise(const double* B, int rank, int n, double* x, double* coef) {
    if (coef) std::fill(coef, coef + rank, 0.0);
    for (int pass = 0; pass < 2; ++pass)
        for (int i = 0; i < rank; ++i) {
            const double s = dot_n(B + i * n, x, n);
            for (int k = 0; k < n; ++k) x[k] -= s * B[i * n + k];
            if (coef) coef[i] += s;
        }
}

// U (rows): an orthonormal basis of the row space of J (m x nv); returns its rank.
int row_space(const double* J, int m, int nv, double* U) {
    double largest = 0.0;
    for (int r = 0; r < m; ++r) largest = std::max(largest, norm_n(J + r * nv, nv));
    int rank = 0;
    for (int r = 0; r < m && rank < nv; ++r) {
        double* u = U + rank * nv;
        std::copy(J + r * nv, J + (r + 1) * nv, u);
        orthogonalise(U, rank, nv, u, nullptr);
        const double rho = norm_n(u, nv);
        if (!(rho > 1e-9 * largest)) continue;  // dependent on the rows before it
        for (int k = 0; k < nv; ++k) u[k] /= rho;
        ++rank;
    }
    return rank;
}

// x = P x = x - U^T (U x), U's rank rows orthonormal.
void project(const double* U, int rank, int nv, double* x) { orthogonalise(U, rank, nv, x, nullptr); }

}  // namespace

int constrained_inverse_dynamics(const Model& model, const Constraints& con, Data& data, ConstrainedInverseData& w,
                                 const double* q, const double* v, const double* a, const Vec3& gravity,
                                 const double* actuated, double* tau) {
    const int nv = model.nv, m = con.m;
    ConstrainedData& cd = w.cd;
    double* f = w.f.data();
    rnea(model, data, q, v, a, gravity, nullptr, true, true, f);  // f = M a + C v + g
    constraint_terms(model, con, data, cd.w, q, v, cd.phi.data(), cd.J.data(), cd.gamma.data());
    if (!satisfies_constraints(cd.J.data(), cd.gamma.data(), a, m, nv)) return ID_VIOLATES;
    const int rank = row_space(cd.J.data(), m, nv, w.U.data());
    std::copy(f, f + nv, w.Pf.begin());
    project(w.U.data(), rank, nv, w.Pf.data());
    // W C = P S over the actuated coordinates (column j of C for the j-th actuated coordinate, C nv x na)
    int na = 0, r2 = 0;
    for (int k = 0; k < nv; ++k)
        if (actuated[k] != 0.0) w.act[na++] = k;
    double *W = w.W.data(), *C = w.C.data();
    for (int j = 0; j < na; ++j) {
        double* x = W + r2 * nv;
        std::fill(x, x + nv, 0.0);
        x[w.act[j]] = 1.0;
        project(w.U.data(), rank, nv, x);
        const double size = norm_n(x, nv);
        orthogonalise(W, r2, nv, x, w.c.data());
        for (int i = 0; i < nv; ++i) C[i * nv + j] = i < r2 ? w.c[i] : 0.0;
        const double rho = norm_n(x, nv);
        w.kept[j] = rho > 1e-10 * size && size > 0.0;
        if (!w.kept[j]) continue;
        for (int k = 0; k < nv; ++k) x[k] /= rho;
        C[r2 * nv + j] = rho;
        ++r2;
    }
    for (int i = 0; i < r2; ++i) w.c[i] = dot_n(W + i * nv, w.Pf.data(), nv);  // c = W^T P f
    std::fill(tau, tau + nv, 0.0);
    if (r2 == na) {  // C square upper triangular: back substitution
        for (int j = na - 1; j >= 0; --j) {
            double x = w.c[j];
            for (int k = j + 1; k < na; ++k) x -= C[j * nv + k] * w.y[k];
            w.y[j] = x / C[j * nv + j];
        }
    } else {  // redundant actuators: the minimum-norm y = C^T (C C^T)^-1 c
        double* CC = w.CC.data();
        for (int r = 0; r < r2; ++r)
            for (int s = 0; s <= r; ++s) CC[r * nv + s] = dot_n(C + r * nv, C + s * nv, na);
        cholesky(CC, nv, r2, 0.0);
        lower_solve(CC, nv, r2, w.c.data());
        upper_solve(CC, nv, r2, w.c.data());
        for (int j = 0; j < na; ++j) {
            double x = 0.0;
            for (int r = 0; r < r2; ++r) x += C[r * nv + j] * w.c[r];
            w.y[j] = x;
        }
    }
    for (int j = 0; j < na; ++j) tau[w.act[j]] = w.y[j];
    // the residual P S tau - P f against the size of f
    std::copy(tau, tau + nv, w.c.begin());
    project(w.U.data(), rank, nv, w.c.data());
    double res = 0.0, s = 0.0;
    for (int k = 0; k < nv; ++k) {
        res = std::max(res, std::abs(w.c[k] - w.Pf[k]));
        s = std::max(s, std::max(std::abs(w.Pf[k]), std::abs(f[k])));
    }
    return res > 1e-8 * std::max(s, 1e-6) ? ID_UNREACHABLE : ID_DONE;
}

}  // namespace core
