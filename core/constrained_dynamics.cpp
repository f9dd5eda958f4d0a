// Constrained forward dynamics by the KKT system (constrained_dynamics.hpp has the equations).
#include "constrained_dynamics.hpp"

#include <algorithm>
#include <cmath>

#include "configuration.hpp"
#include "crba.hpp"
#include "rnea.hpp"

namespace core {

void ConstrainedData::resize(const Model& model, const Constraints& con) {
    const size_t nv = model.nv, m = con.m;
    w.resize(model);
    L.resize(nv * nv), lam.resize(nv), J.resize(m * nv), Y.resize(m * nv), phi.resize(m), gamma.resize(m);
    f.resize(nv), K.resize(m * m), LK.resize(m * m), rhs.resize(m), t.resize(m), mu.resize(m), piv.resize(m);
    dq.resize(nv), delta.resize(nv), qn.resize(model.nq);
}

// M(q) = L^T L (Table 6.3, the LTL factorisation), cost sum_k depth(k)^2.  Returns -1, or the body whose joint
// has a non-positive pivot.
int mass_factor(const Model& model, Data& data, const double* q, double* L, int* lam) {
    const int nv = model.nv;
    crba(model, data, q, L);  // the entries of coordinate pairs on one path to the root, the only ones read
    dof_parents(model, lam);
    for (int k = nv - 1; k >= 0; --k) {
        double d = L[k * nv + k];
        if (!(d > 0.0)) {
            for (int i = 0; i < model.nb; ++i)
                if (model.v_idx[i] <= k && k < model.v_idx[i] + model.nv_j[i]) return i;
            return 0;
        }
        d = std::sqrt(d);
        L[k * nv + k] = d;
        for (int i = lam[k]; i >= 0; i = lam[i]) L[k * nv + i] /= d;
        for (int i = lam[k]; i >= 0; i = lam[i])
            for (int j = i; j >= 0; j = lam[j]) L[i * nv + j] -= L[k * nv + i] * L[k * nv + j];
    }
    return -1;
}

// x = L^-T x (from the leaves to the root).
void ltl_solve_t(const double* L, const int* lam, int nv, double* x) {
    for (int i = nv - 1; i >= 0; --i) {
        x[i] /= L[i * nv + i];
        for (int j = lam[i]; j >= 0; j = lam[j]) x[j] -= L[i * nv + j] * x[i];
    }
}

// x = L^-1 x (from the root to the leaves).
void ltl_solve(const double* L, const int* lam, int nv, double* x) {
    for (int i = 0; i < nv; ++i) {
        double y = x[i];
        for (int j = lam[i]; j >= 0; j = lam[j]) y -= L[i * nv + j] * x[j];
        x[i] = y / L[i * nv + i];
    }
}

// Y = (L^-T J^T)^T (row r = L^-T J[r], skipping the zeros of sparse rows) and K = Y Y^T.
static void delassus(const double* L, const int* lam, int nv, int m, const double* J, double* Y, double* K) {
    for (int r = 0; r < m; ++r) {
        double* y = Y + r * nv;
        std::copy(J + r * nv, J + (r + 1) * nv, y);
        for (int i = nv - 1; i >= 0; --i) {
            const double x = y[i] / L[i * nv + i];
            y[i] = x;
            if (x != 0.0)
                for (int j = lam[i]; j >= 0; j = lam[j]) y[j] -= L[i * nv + j] * x;
        }
    }
    for (int r = 0; r < m; ++r)
        for (int s = r; s < m; ++s) {
            double x = 0.0;
            for (int k = 0; k < nv; ++k) x += Y[r * nv + k] * Y[s * nv + k];
            K[r * m + s] = x;
            K[s * m + r] = x;
        }
}

// A[:n, :n] = L L^T in place (lower triangle; ld the row stride).  False when a pivot is <= tol.
bool cholesky(double* A, int ld, int n, double tol) {
    for (int j = 0; j < n; ++j) {
        double d = A[j * ld + j];
        for (int k = 0; k < j; ++k) d -= A[j * ld + k] * A[j * ld + k];
        if (!(d > tol)) return false;
        d = std::sqrt(d);
        A[j * ld + j] = d;
        for (int r = j + 1; r < n; ++r) {
            double y = A[r * ld + j];
            for (int k = 0; k < j; ++k) y -= A[r * ld + k] * A[j * ld + k];
            A[r * ld + j] = y / d;
        }
    }
    return true;
}

void lower_solve(const double* L, int ld, int n, double* x) {
    for (int r = 0; r < n; ++r) {
        double y = x[r];
        for (int k = 0; k < r; ++k) y -= L[r * ld + k] * x[k];
        x[r] = y / L[r * ld + r];
    }
}

void upper_solve(const double* L, int ld, int n, double* x) {
    for (int r = n - 1; r >= 0; --r) {
        double y = x[r];
        for (int k = r + 1; k < n; ++k) y -= L[k * ld + r] * x[k];
        x[r] = y / L[r * ld + r];
    }
}

// P^T K P = L L^T with diagonal pivoting (Golub & Van Loan, Algorithm 4.2.4 as an outer product), stopping where
// the largest pivot left is <= tol; returns the rank r (L's columns beyond it zero).  piv[i]: K's row at i.
int pivoted_cholesky(const double* K, int m, double tol, double* L, int* piv) {
    std::copy(K, K + m * m, L);
    for (int i = 0; i < m; ++i) piv[i] = i;
    for (int j = 0; j < m; ++j) {
        int p = j;
        for (int i = j + 1; i < m; ++i)
            if (L[i * m + i] > L[p * m + p]) p = i;
        if (!(L[p * m + p] > tol)) {  // the trailing block is the dependent rows' round-off: dropped
            for (int i = 0; i < m; ++i)
                for (int c = j; c < m; ++c) L[i * m + c] = 0.0;
            return j;
        }
        if (p != j) {  // swap rows and columns j and p (the trailing block is kept symmetric)
            std::swap(piv[j], piv[p]);
            for (int c = 0; c < m; ++c) std::swap(L[j * m + c], L[p * m + c]);
            for (int r = 0; r < m; ++r) std::swap(L[r * m + j], L[r * m + p]);
        }
        const double d = std::sqrt(L[j * m + j]);
        L[j * m + j] = d;
        for (int r = j + 1; r < m; ++r) L[r * m + j] /= d;
        for (int r = j + 1; r < m; ++r)
            for (int c = j + 1; c < m; ++c) L[r * m + c] -= L[r * m + j] * L[c * m + j];
        for (int c = j + 1; c < m; ++c) L[j * m + c] = 0.0;
    }
    return m;
}

// x = K^+ rhs for a symmetric positive semidefinite K (m x m; overwritten when rows are dependent); L (m x m), piv
// and t (m) scratch.  Returns the rank.
int pinv_solve(double* K, int m, const double* rhs, double rtol, double* x, double* L, int* piv, double* t) {
    if (m == 0) return 0;
    double dmax = 0.0;
    for (int r = 0; r < m; ++r) dmax = std::max(dmax, K[r * m + r]);
    std::copy(K, K + m * m, L);
    if (dmax > 0.0 && cholesky(L, m, m, CHOLESKY_RTOL * dmax)) {
        std::copy(rhs, rhs + m, x);
        lower_solve(L, m, m, x);
        upper_solve(L, m, m, x);
        return m;
    }
    const int rank = pivoted_cholesky(K, m, rtol * dmax, L, piv);
    for (int r = 0; r < rank; ++r) t[r] = rhs[piv[r]];  // z = L1^-1 (P^T rhs)[:r]
    lower_solve(L, m, rank, t);
    for (int a = 0; a < rank; ++a)  // G = L^T L (rank x rank, lower triangle) in K
        for (int b = 0; b <= a; ++b) {
            double y = 0.0;
            for (int r = 0; r < m; ++r) y += L[r * m + a] * L[r * m + b];
            K[a * m + b] = y;
        }
    cholesky(K, m, rank, 0.0);  // positive definite: L's r columns are independent
    lower_solve(K, m, rank, t);  // w = G^-1 z
    upper_solve(K, m, rank, t);
    for (int r = 0; r < m; ++r) {  // x = P L w
        double y = 0.0;
        for (int a = 0; a < rank; ++a) y += L[r * m + a] * t[a];
        x[piv[r]] = y;
    }
    return rank;
}

int constrained_forward_dynamics(const Model& model, const Constraints& con, Data& data, ConstrainedData& cd,
                                 const double* q, const double* v, const double* tau, const Vec3& gravity,
                                 double alpha, double beta, double* a, double* lambda) {
    const int nv = model.nv, m = con.m;
    const int status = mass_factor(model, data, q, cd.L.data(), cd.lam.data());
    if (status >= 0) return status;
    double* f = cd.f.data();
    rnea(model, data, q, v, v, gravity, nullptr, true, false, f);  // f = C v + g
    for (int k = 0; k < nv; ++k) f[k] = tau[k] - f[k];
    ltl_solve_t(cd.L.data(), cd.lam.data(), nv, f);  // f = L^-T (tau - C v - g)
    constraint_terms(model, con, data, cd.w, q, v, cd.phi.data(), cd.J.data(), cd.gamma.data());
    delassus(cd.L.data(), cd.lam.data(), nv, m, cd.J.data(), cd.Y.data(), cd.K.data());
    const double *J = cd.J.data(), *Y = cd.Y.data();
    for (int r = 0; r < m; ++r) {  // rhs = -(J M^-1 f + gamma + 2 alpha J v + beta^2 phi), J M^-1 f = Y L^-T f
        double x = cd.gamma[r] + beta * beta * cd.phi[r];
        for (int c = 0; c < nv; ++c) x += Y[r * nv + c] * f[c] + 2.0 * alpha * J[r * nv + c] * v[c];
        cd.rhs[r] = -x;
    }
    pinv_solve(cd.K.data(), m, cd.rhs.data(), RANK_RTOL, lambda, cd.LK.data(), cd.piv.data(), cd.t.data());
    for (int k = 0; k < nv; ++k) a[k] = f[k];  // a = L^-1 (L^-T f + Y^T lambda)
    for (int r = 0; r < m; ++r)
        for (int k = 0; k < nv; ++k) a[k] += Y[r * nv + k] * lambda[r];
    ltl_solve(cd.L.data(), cd.lam.data(), nv, a);
    return -1;
}

void constraint_drift(const Model& model, const Constraints& con, Data& data, ConstrainedData& cd, const double* q,
                      const double* v, double& position, double& velocity) {
    const int nv = model.nv;
    constraint_terms(model, con, data, cd.w, q, v, cd.phi.data(), cd.J.data(), nullptr);
    position = 0.0, velocity = 0.0;
    for (int r = 0; r < con.m; ++r) {
        position = std::max(position, std::abs(cd.phi[r]));
        double x = 0.0;
        for (int c = 0; c < nv; ++c) x += cd.J[r * nv + c] * v[c];
        velocity = std::max(velocity, std::abs(x));
    }
}

int project_velocity(const Model& model, const Constraints& con, Data& data, ConstrainedData& cd, const double* q,
                     const double* v, double* v_out) {
    const int nv = model.nv, m = con.m;
    const int status = mass_factor(model, data, q, cd.L.data(), cd.lam.data());
    if (status >= 0) return status;
    constraint_terms(model, con, data, cd.w, q, v, cd.phi.data(), cd.J.data(), nullptr);
    delassus(cd.L.data(), cd.lam.data(), nv, m, cd.J.data(), cd.Y.data(), cd.K.data());
    for (int r = 0; r < m; ++r) {
        double x = 0.0;
        for (int c = 0; c < nv; ++c) x += cd.J[r * nv + c] * v[c];
        cd.rhs[r] = -x;
    }
    pinv_solve(cd.K.data(), m, cd.rhs.data(), RANK_RTOL, cd.mu.data(), cd.LK.data(), cd.piv.data(), cd.t.data());
    double* f = cd.f.data();
    std::fill(f, f + nv, 0.0);
    for (int r = 0; r < m; ++r)  // M^-1 J^T mu = L^-1 Y^T mu
        for (int k = 0; k < nv; ++k) f[k] += cd.Y[r * nv + k] * cd.mu[r];
    ltl_solve(cd.L.data(), cd.lam.data(), nv, f);
    for (int k = 0; k < nv; ++k) v_out[k] = v[k] + f[k];
    return -1;
}

double project_position(const Model& model, const Constraints& con, Data& data, ConstrainedData& cd, const double* q,
                        double tol, int max_iter, double* q_out) {
    const int nv = model.nv, m = con.m;
    std::copy(q, q + model.nq, q_out);
    double err = 0.0;
    for (int it = 0; it <= max_iter; ++it) {
        constraint_terms(model, con, data, cd.w, q_out, nullptr, cd.phi.data(), cd.J.data(), nullptr);
        err = 0.0;
        for (int r = 0; r < m; ++r) err = std::max(err, std::abs(cd.phi[r]));
        if (err <= tol || it == max_iter) break;
        const double* J = cd.J.data();
        for (int r = 0; r < m; ++r)  // K = J J^T
            for (int s = r; s < m; ++s) {
                double x = 0.0;
                for (int k = 0; k < nv; ++k) x += J[r * nv + k] * J[s * nv + k];
                cd.K[r * m + s] = x;
                cd.K[s * m + r] = x;
            }
        pinv_solve(cd.K.data(), m, cd.phi.data(), RANK_RTOL, cd.mu.data(), cd.LK.data(), cd.piv.data(), cd.t.data());
        for (int k = 0; k < nv; ++k) {  // dq = J^T mu
            double x = 0.0;
            for (int r = 0; r < m; ++r) x += J[r * nv + k] * cd.mu[r];
            cd.dq[k] = x;
        }
        integrate(model, q_out, cd.dq.data(), -1.0, cd.delta.data(), cd.qn.data());
        std::copy(cd.qn.begin(), cd.qn.end(), q_out);
    }
    return err;
}

}  // namespace core
