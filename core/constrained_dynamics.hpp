// Constrained forward dynamics: the KKT system of a closed-loop or coupled mechanism (the C++ side of
// dynamics/constrained_dynamics.py, whose docstring has the derivation; the same steps in the same order).
//
//     M a + C v + g = tau + J^T lambda,        J a + gamma = -(2 alpha J v + beta^2 phi)
//
// (J = Phi_q, gamma = Phi_q_dot v, phi of constraints.hpp; Baumgarte's gains alpha, beta in 1/s, 0 for none).
// Eliminating a with f = tau - C v - g:
//
//     K = J M^-1 J^T,   K lambda = -(J M^-1 f + gamma + 2 alpha J v + beta^2 phi),   a = M^-1 (f + J^T lambda).
//
// M from the CRBA, factored M = L^T L with no fill-in (Featherstone 2008, sec. 6.5, Table 6.3: L[k, c] != 0 only
// where c is k or an ancestor coordinate of k); with Y = (L^-T J^T)^T: K = Y Y^T, J M^-1 f = Y (L^-T f),
// a = L^-1 (L^-T f + Y^T lambda).  lambda = K^+ rhs, the minimum-norm multipliers: a Cholesky factor of K while
// its pivots stay above CHOLESKY_RTOL times K's largest diagonal entry, else Cholesky with diagonal pivoting
// stopped at the rank (RANK_RTOL) and the minimum-norm solution from the r x r Gram matrix of the factor.
#pragma once

#include <vector>

#include "constraints.hpp"

namespace core {

//: pivots of K's pivoted Cholesky factor below this times K's largest diagonal entry are dependent rows
constexpr double RANK_RTOL = 1e-12;
//: a Cholesky pivot of K below this times K's largest diagonal entry sends the solve to the pivoted factor
constexpr double CHOLESKY_RTOL = 1e-10;

// The KKT solve's workspace (one per call or per thread, never shared), sizes in the comments.
struct ConstrainedData {
    ConstraintWork w;
    std::vector<double> L;              // nv x nv: M = L^T L (only (k, k) and (k, ancestor of k) are L)
    std::vector<int> lam;               // nv: the velocity coordinate before k on the path to the root, -1 at it
    std::vector<double> J, Y;           // m x nv: Phi_q and (L^-T J^T)^T
    std::vector<double> phi, gamma;     // m
    std::vector<double> f;              // nv: L^-T (tau - C v - g)
    std::vector<double> K, LK;          // m x m: the Delassus matrix and its factor
    std::vector<double> rhs, t, mu;     // m
    std::vector<int> piv;               // m: K's pivot order
    std::vector<double> dq, delta, qn;  // nv, nv, nq: a projection's step
    void resize(const Model& model, const Constraints& con);
};

// a (nv) and lambda (m) at (q, v, tau) with gravity and Baumgarte gains alpha, beta.  Returns -1, or the body
// whose joint makes M singular (then a and lambda are not valid).
int constrained_forward_dynamics(const Model& model, const Constraints& con, Data& data, ConstrainedData& cd,
                                 const double* q, const double* v, const double* tau, const Vec3& gravity,
                                 double alpha, double beta, double* a, double* lambda);

// (max |phi(q)|, max |Phi_q v|): the position and velocity residuals of one state.
void constraint_drift(const Model& model, const Constraints& con, Data& data, ConstrainedData& cd, const double* q,
                      const double* v, double& position, double& velocity);

// v_out = v - M^-1 J^T K^+ J v: the velocity nearest v in the kinetic-energy metric with J v_out = 0.  Returns -1
// or the body whose joint makes M singular.
int project_velocity(const Model& model, const Constraints& con, Data& data, ConstrainedData& cd, const double* q,
                     const double* v, double* v_out);

// q_out = q moved onto phi = 0 by Gauss-Newton with minimum-norm steps, q_{k+1} = q_k (+) (-J^+ phi), J^+ phi =
// J^T (J J^T)^+ phi (the pseudo-inverse of K = J J^T as pinv_solve takes it), at most max_iter steps (near the
// manifold, after an accepted step, it converges quadratically).  Returns max |phi(q_out)|; above tol the
// projection failed.  q_out may not alias q.
double project_position(const Model& model, const Constraints& con, Data& data, ConstrainedData& cd, const double* q,
                        double tol, int max_iter, double* q_out);

// The KKT solve's linear algebra, shared with constrained_derivatives and constrained_inverse_dynamics (row-major
// matrices; ld the row stride).

// M(q) = L^T L (Table 6.3, the LTL factorisation) into L (nv x nv), lam the coordinates' parents.  Returns -1, or
// the body whose joint has a non-positive pivot.
int mass_factor(const Model& model, Data& data, const double* q, double* L, int* lam);
// x = L^-T x (from the leaves to the root) and x = L^-1 x (from the root to the leaves).
void ltl_solve_t(const double* L, const int* lam, int nv, double* x);
void ltl_solve(const double* L, const int* lam, int nv, double* x);
// A[:n, :n] = L L^T in place (lower triangle).  False when a pivot is <= tol.
bool cholesky(double* A, int ld, int n, double tol);
// x[:n] = L[:n, :n]^-1 x[:n] and x[:n] = L[:n, :n]^-T x[:n] in place.
void lower_solve(const double* L, int ld, int n, double* x);
void upper_solve(const double* L, int ld, int n, double* x);
// P^T K P = L L^T with diagonal pivoting (K, L m x m), stopping where the largest pivot left is <= tol; returns the
// rank (L's columns beyond it zero); piv[i]: K's row at i.
int pivoted_cholesky(const double* K, int m, double tol, double* L, int* piv);
// x = K^+ rhs for a symmetric positive semidefinite K (m x m; overwritten when rows are dependent); L (m x m), piv
// and t (m) scratch.  Returns the rank.
int pinv_solve(double* K, int m, const double* rhs, double rtol, double* x, double* L, int* piv, double* t);

}  // namespace core
