// Numerical pieces shared by the solvers: LU with partial pivoting (real and complex) that visits only each row's
// envelope, the scaled RMS norm, the state check, Hairer's starting step, the finite-difference Jacobian and a
// spectral-radius estimate ([HNW] = Hairer, Norsett & Wanner, "Solving ODEs I", 2nd ed. 1993).
#pragma once

#include <complex>
#include <vector>

#include "solver.hpp"

namespace core::sim {

// In-place LU with partial pivoting of the n x n row-major A (P A = L U, L unit lower triangular) that visits only
// each row's and column's envelope (the span of its nonzeros, widened by the fill-in as it comes): the same factors
// bit for bit as the dense algorithm (only exact zeros are skipped), in O(n b^2) for a block-diagonal A of b x b
// blocks (radau's Newton matrix of the sensitivities' augmented system).  env (3 n) receives, for envelope_lu_solve:
// env[i] the first column of row i's multipliers, env[n + i] the last nonzero column of row i of U; env[2n..3n) is
// scratch.  A zero pivot is skipped: the solve returns inf/nan and the step is rejected.
template <class T>
void envelope_lu_factor(T* A, int n, int* piv, int* env);
template <class T>
void envelope_lu_solve(const T* LU, int n, const int* piv, const int* env, T* b);

// Dense LU with partial pivoting (small systems: the sensitivities' chart matrices; complex: the reference the
// envelope LU is tested against).
template <class T>
void lu_factor(T* A, int n, int* piv);
template <class T>
void lu_solve(const T* LU, int n, const int* piv, T* b);

// RMS of e_i / (atol + rtol max(|z0_i| + mag_i, |z1_i| + mag_i)) over the first ne components.
double scaled_rms(const double* e, const double* z0, const double* z1, const double* mag, int ne, double rtol,
                  double atol);
// max |x_i| over the first ne (NaN propagates).
double max_abs(const double* x, int ne);
// OK, NONFINITE or BLOWUP for a state of n components (velocities z[nc .. nc + nvel) above blowup: BLOWUP).
Status state_status(const double* z, int n, int nc, int nvel, double blowup);
// Hairer's starting step ([HNW] sec. II.4), as scipy's select_initial_step.
double initial_step(Problem& p, double t, const double* z, const double* f0, int n, int order, double rtol, double atol,
                    const double* mag, int ne, double t_end, Stats& st);
// J (n x n) = df/dz by forward differences; columns of the quadratures (>= ne) are zero.
void fd_jacobian(Problem& p, double t, const double* z, const double* f0, const double* mag, int n, int ne, double* J,
                 Stats& st);
// The problem's own Jacobian when it has one, else fd_jacobian.
void problem_jacobian(Problem& p, double t, const double* z, const double* f0, const double* mag, int n, int ne,
                      double* J, Stats& st);
// max |lambda(J)| over the leading ne x ne block of the n x n J, by 30 power iterations (geometric mean of the last
// 15 growth ratios: also the modulus of a dominant complex pair).
double spectral_radius(const double* J, int n, int ne);
// The spectral radius of df/dz at (t, z), without counting the evaluations in the run's statistics (the
// fixed-step methods' stability probe).
double jacobian_spectral_radius(Problem& p, double t, const double* z, const double* f0, int n, int ne);

}  // namespace core::sim
