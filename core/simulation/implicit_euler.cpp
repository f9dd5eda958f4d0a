// Linearly implicit Euler, first order, fixed step: symplectic Euler whose velocity update treats the stiff forces
// (contact, the passive torques, a PD source) implicitly, one linear solve per step - the step MuJoCo's Euler and
// implicitfast integrators take, so that a 2 ms step holds a robot standing on stiff, damped, frictional contacts.
//
// With a = f(q, v) the accelerations, D = d tau/dv and K = d tau/dq the stiff forces' derivatives at the step's
// start and M the mass matrix, linearising a(q+, v+) about (q, v) with q+ = q (+) h v+ gives
//     (M - h D - h^2 K) dv = h (M a + h K v),    v+ = v + dv,    q+ = q (+) h v+
// ([HW] = Hairer & Wanner, "Solving ODEs II", sec. IV.7: Rosenbrock's one-stage method, with the Jacobian's stiff
// part only; the rest of the dynamics stays explicit).  M a = tau - C v - g + J_c^T f_c comes from the RNEA, not
// the ABA: the step factors M anyway, so it needs no accelerations and the driver evaluates no slopes
// (needs_slope).  The quadratures by explicit Euler.  A problem without these terms (closed loops): symplectic
// Euler's step (euler.cpp).  Samples between steps: linear interpolation.
//
// The matrix A = M - h D - h^2 K has M's branch-induced sparsity when every stiff force acts along one path to
// the root (a body against the world: the problem then hands over Featherstone's lambda): A is factored along the
// tree as the LTL factorisation of M is (Featherstone 2008, sec. 6.5), without pivoting and without fill-in, in
// sum_k depth(k)^2 operations.  A couples two branches (a robot touching itself) or a pivot is not positive: dense
// LU with partial pivoting.
#include <algorithm>
#include <cmath>
#include <vector>

#include "linalg.hpp"
#include "methods.hpp"

namespace core::sim {

namespace {

// y = A x over the entries of A on a path to the root (lam's chains; the others are not read).
void tree_product(const double* A, const int* lam, int n, const double* x, double* y) {
    for (int k = 0; k < n; ++k) y[k] = A[k * n + k] * x[k];
    for (int k = 0; k < n; ++k)
        for (int j = lam[k]; j >= 0; j = lam[j]) {
            y[k] += A[k * n + j] * x[j];
            y[j] += A[j * n + k] * x[k];
        }
}

// In place, from the leaves to the root: coordinate k is eliminated from the rows of its ancestors (the only rows
// holding it), whose multipliers are kept where A's entries were.  false: a pivot that is not positive.
bool tree_lu_factor(double* A, const int* lam, int n) {
    for (int k = n - 1; k >= 0; --k) {
        const double d = A[k * n + k];
        if (!(d > 0.0) || !std::isfinite(d)) return false;
        for (int i = lam[k]; i >= 0; i = lam[i]) {
            const double l = A[i * n + k] / d;
            A[i * n + k] = l;
            for (int j = lam[k]; j >= 0; j = lam[j]) A[i * n + j] -= l * A[k * n + j];  // (i among the j)
        }
    }
    return true;
}

// b = A^-1 b with tree_lu_factor's factors: the eliminations from the leaves, then back-substitution from the root.
void tree_lu_solve(const double* A, const int* lam, int n, double* b) {
    for (int k = n - 1; k >= 0; --k)
        for (int i = lam[k]; i >= 0; i = lam[i]) b[i] -= A[i * n + k] * b[k];
    for (int k = 0; k < n; ++k) {
        double s = b[k];
        for (int j = lam[k]; j >= 0; j = lam[j]) s -= A[k * n + j] * b[j];
        b[k] = s / A[k * n + k];
    }
}

// M, D, K and A (nv x nv): a step's scratch, nothing kept from one step to the next, so one per thread rather than
// per environment (a batch of a thousand Go1 then steps in 10 KB of matrices that stay in cache, not 10 MB).
struct Matrices {
    std::vector<double> M, D, K, A;
};

Matrices& matrices(int nv) {
    thread_local Matrices w;
    const size_t n2 = static_cast<size_t>(nv) * nv;
    if (w.M.size() != n2) w.M.assign(n2, 0.0), w.D.assign(n2, 0.0), w.K.assign(n2, 0.0), w.A.assign(n2, 0.0);
    return w;
}

class ImplicitEuler : public FixedStepper {
public:
    ImplicitEuler(int nv, int n)
        : nv_(nv), n_(n), b_(nv),
          Kv_(nv), f_(n), piv_(nv) {}

    bool needs_slope() const override { return false; }
    void step(Problem& p, double t, double h, double* z, const double*, Stats& st) override {
        const int nv = nv_;
        double* v = z + nv;
        const int* lam = nullptr;
        st.rhs_evals += 1;
        Matrices& w = matrices(nv);
        if (p.implicit_terms(t, z, b_.data(), f_.data(), w.M.data(), w.D.data(), w.K.data(), lam)) {
            solve(w, h, v, lam);
            st.jacobian_evals += 1, st.lu_decompositions += 1;
            for (int r = 0; r < nv; ++r) v[r] += b_[r];
        } else {  // symplectic Euler
            p.rhs(t, z, f_.data());
            for (int r = 0; r < nv; ++r) v[r] += h * f_[nv + r];
        }
        for (int r = 2 * nv; r < n_; ++r) z[r] += h * f_[r];
        p.euler_config(z, h);
    }
    void dense(double x, double, const double* z0, const double*, const double* z1, const double*,
               double* out) override {
        for (int r = 0; r < n_; ++r) out[r] = z0[r] + x * (z1[r] - z0[r]);
    }

private:
    // b_ = dv = A^-1 h (r + h K v) (r = M a on entry), A = M - h D - h^2 K: along the tree when lam is given and
    // every pivot is positive, else dense (a singular A: inf/nan in dv, and the driver stops with NONFINITE).
    void solve(Matrices& w, double h, const double* v, const int* lam) {
        const int nv = nv_;
        const double *M = w.M.data(), *D = w.D.data(), *K = w.K.data();
        double* A = w.A.data();
        if (lam) {
            tree_product(K, lam, nv, v, Kv_.data());
        } else {
            for (int r = 0; r < nv; ++r) {
                double Kv = 0.0;
                for (int c = 0; c < nv; ++c) Kv += K[r * nv + c] * v[c];
                Kv_[r] = Kv;
            }
        }
        for (int r = 0; r < nv; ++r) b_[r] = h * (b_[r] + h * Kv_[r]);
        if (lam) {
            assemble(w, h, lam);
            if (tree_lu_factor(A, lam, nv)) {
                tree_lu_solve(A, lam, nv, b_.data());
                return;
            }
            std::fill(w.A.begin(), w.A.end(), 0.0);  // (the entries off the paths: zero in M, D and K)
            assemble(w, h, lam);
        } else {
            for (size_t k = 0; k < w.A.size(); ++k) A[k] = M[k] - h * D[k] - h * h * K[k];
        }
        lu_factor(A, nv, piv_.data());
        lu_solve(A, nv, piv_.data(), b_.data());
    }
    // A's entries on the paths to the root
    void assemble(Matrices& w, double h, const int* lam) const {
        const int nv = nv_;
        const double *M = w.M.data(), *D = w.D.data(), *K = w.K.data();
        double* A = w.A.data();
        const double h2 = h * h;
        for (int k = 0; k < nv; ++k) {
            const int kk = k * nv + k;
            A[kk] = M[kk] - h * D[kk] - h2 * K[kk];
            for (int j = lam[k]; j >= 0; j = lam[j]) {
                const int kj = k * nv + j, jk = j * nv + k;
                A[kj] = M[kj] - h * D[kj] - h2 * K[kj];
                A[jk] = M[jk] - h * D[jk] - h2 * K[jk];
            }
        }
    }

    int nv_, n_;
    std::vector<double> b_, Kv_, f_;  // nv; nv; n (the quadratures' rates, or f)
    std::vector<int> piv_;
};

}  // namespace

std::unique_ptr<FixedStepper> make_implicit_euler(int nc, int n) { return std::make_unique<ImplicitEuler>(nc, n); }

}  // namespace core::sim
