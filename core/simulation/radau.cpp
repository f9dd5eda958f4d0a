// Radau IIA of order 5 (3 stages, L-stable, stiffly accurate) with a simplified Newton iteration on the problem's
// Jacobian (analytical for the robot, finite differences for a problem without one), the real/complex splitting of
// the stage system, the embedded third-order error estimate filtered through (1 - h gamma J)^-1 and Gustafsson's
// predictive controller ([HW] sec. IV.8; the structure follows scipy.integrate.Radau).  Dense output: the
// collocation polynomial of the step.  [HW] = Hairer & Wanner, "Solving ODEs II", 2nd ed. 1996.
#include "radau.hpp"

#include <algorithm>
#include <cmath>

#include "linalg.hpp"
#include "methods.hpp"

namespace core::sim {

namespace {

// Radau IIA(5) ([HW] sec. IV.8): nodes, error weights, the eigenvalues of A^-1 (mu_real, mu_complex), A = T diag T^-1,
// the dense output's polynomial
constexpr double C[3] = {0.15505102572168222, 0.6449489742783178, 1.0};
constexpr double E[3] = {-10.048809399827414, 1.382142733160748, -0.3333333333333333};
constexpr double MU_REAL = 3.637834252744496, MU_CRE = 2.6810828736277523, MU_CIM = -3.050430199247411;
constexpr double T[3][3] = {
    {0.09443876248897524, -0.1412552950209542, 0.03002919410514742},
    {0.2502131229653333, 0.20412935229379994, -0.3829421127572619},
    {1.0, 1.0, 0.0}};
constexpr double TI[3][3] = {
    {4.178718591551904, 0.32768282076106237, 0.5233764454994495},
    {-4.178718591551904, -0.32768282076106237, 0.47662355450055044},
    {0.5028726349457868, -2.571926949855605, 0.5960392048282249}};
constexpr double P[3][3] = {
    {10.048809399827414, -25.62959144707664, 15.580782047249224},
    {-1.382142733160748, 10.296258113743303, -8.914115380582556},
    {0.3333333333333333, -2.6666666666666665, 3.3333333333333335}};
constexpr int NEWTON_MAXITER = 6;
constexpr double EPS = 2.220446049250313e-16;

}  // namespace

Radau::Radau(int n)
    : n_(n), J_(static_cast<size_t>(n) * n), LUr_(J_.size()), LUc_(J_.size()), pivr_(n), pivc_(n), envr_(3 * n),
      envc_(3 * n), Z_(3 * static_cast<size_t>(n)), W_(Z_.size()), F_(Z_.size()), Qd_(Z_.size()), zs_(n), dWr_(n),
      dWc_(n) {
    reset();
}

void Radau::reset() {
    need_jac_ = true, current_jac_ = false, have_lu_ = false, have_sol_ = false;
    h_sol_ = 1.0, h_abs_old_ = -1.0, err_norm_old_ = -1.0, rho_ = -1.0;
}

// Solve the stage system (a fresh Jacobian once if Newton fails), estimate the error, run Gustafsson's controller;
// on acceptance also f at the new point (Radau is not FSAL).
bool Radau::attempt(Problem& p, double t, double h, const double* z, const double* f0, double* znew, double* fnew,
                    double* errv, const double* mag, const Options& opt, Stats& st, std::vector<Switch>&, bool,
                    double& h_next) {
    const int n = n_;
    blocks_ = p.second_order_blocks();  // (the factorisation's structure: a pointer the problem keeps)
    bool converged;
    while (true) {
        if (need_jac_) {
            problem_jacobian(p, t, z, f0, mag, n, opt.ne, J_.data(), st);
            rho_ = spectral_radius(J_.data(), n, opt.ne);
            need_jac_ = false, current_jac_ = true, have_lu_ = false;
        }
        if (!have_lu_) factor(h, st);
        converged = newton(p, t, h, z, mag, opt, st);
        if (converged || current_jac_) break;
        need_jac_ = true;  // retry once with a fresh Jacobian
    }
    if (!converged) {
        have_lu_ = false;
        h_next = h * 0.5;
        return false;
    }
    for (int r = 0; r < n; ++r) znew[r] = z[r] + Z_[2 * n + r];
    const double err = error(h, z, znew, f0, errv, mag, opt);
    if (!std::isfinite(err)) {
        have_lu_ = false;
        h_next = h * 0.25;
        return false;
    }
    const double safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter_);
    // Gustafsson's predictive controller ([HW] IV.8, eq. 8.25)
    const double mult = (err_norm_old_ < 0 || h_abs_old_ < 0 || err == 0)
                            ? 1.0 : h / h_abs_old_ * std::pow(err_norm_old_ / err, 0.25);
    double factor = std::min(1.0, mult) * (err > 0 ? std::pow(err, -0.25) : 10.0);
    if (err > 1) {
        have_lu_ = false;
        h_next = h * std::max(0.2, safety * factor);
        return false;
    }
    const bool recompute_jac = n_iter_ > 2 && rate_ > 1e-3;
    factor = std::min(10.0, safety * factor);
    if (!recompute_jac && factor < 1.2)
        factor = 1.0;
    else
        have_lu_ = false;
    h_abs_old_ = h, err_norm_old_ = err;
    need_jac_ = recompute_jac || need_jac_;
    current_jac_ = false;
    collocation_polynomial(h);
    if (rho_ >= 0 && !(st.h_rho >= h * rho_)) st.h_rho = h * rho_;
    p.rhs(t + h, znew, fnew);
    st.rhs_evals += 1;
    h_next = h * factor;
    return true;
}

// LU of mu_real/h - J and of mu_complex/h - J (the two blocks of the transformed stage system), reduced to the
// velocities for a second-order problem.
void Radau::factor(double h, Stats& st) {
    const int n = n_;
    const double mr = MU_REAL / h;
    const std::complex<double> mc = std::complex<double>(MU_CRE, MU_CIM) / h;
    st.lu_decompositions += 2;
    have_lu_ = true;
    if (blocks_) {
        Sr_.factor(J_.data(), n, *blocks_, mr);
        Sc_.factor(J_.data(), n, *blocks_, mc);
        return;
    }
    for (int r = 0; r < n; ++r) {
        for (int k = 0; k < n; ++k) LUr_[r * n + k] = -J_[r * n + k], LUc_[r * n + k] = -J_[r * n + k];
        LUr_[r * n + r] += mr;
        LUc_[r * n + r] += mc;
    }
    envelope_lu_factor(LUr_.data(), n, pivr_.data(), envr_.data());
    envelope_lu_factor(LUc_.data(), n, pivc_.data(), envc_.data());
}

void Radau::solve_real(double* b) {
    if (blocks_)
        Sr_.solve(b);
    else
        envelope_lu_solve(LUr_.data(), n_, pivr_.data(), envr_.data(), b);
}

void Radau::solve_complex(std::complex<double>* b) {
    if (blocks_)
        Sc_.solve(b);
    else
        envelope_lu_solve(LUc_.data(), n_, pivc_.data(), envc_.data(), b);
}

// Simplified Newton iterations on the transformed stage system ([HW] IV.8, eqs. 8.14-8.16), from the last step's
// collocation polynomial (increments are chart-free to first order) or zero.  Leaves the increments in Z, the
// iteration count and rate; returns whether it converged.
bool Radau::newton(Problem& p, double t, double h, const double* z, const double* mag, const Options& opt, Stats& st) {
    const int n = n_;
    const double mr = MU_REAL / h;
    const std::complex<double> mc = std::complex<double>(MU_CRE, MU_CIM) / h;
    const double newton_tol = std::max(10 * EPS / opt.rtol, std::min(0.03, std::sqrt(opt.rtol)));
    initial_guess(h);
    double dW_norm_old = -1.0;
    rate_ = -1.0, n_iter_ = 0;
    for (int it = 0; it < NEWTON_MAXITER; ++it) {
        n_iter_ = it + 1;
        bool finite = true;
        for (int s = 0; s < 3; ++s) {
            for (int r = 0; r < n; ++r) zs_[r] = z[r] + Z_[s * n + r];
            p.rhs(t + C[s] * h, zs_.data(), &F_[s * n]);
            if (state_status(&F_[s * n], n, 0, 0, INFINITY) != OK) finite = false;
        }
        st.rhs_evals += 3;
        if (!finite) return false;
        for (int r = 0; r < n; ++r) {
            const double F0 = F_[r], F1 = F_[n + r], F2 = F_[2 * n + r];
            dWr_[r] = TI[0][0] * F0 + TI[0][1] * F1 + TI[0][2] * F2 - mr * W_[r];
            dWc_[r] = std::complex<double>(TI[1][0], TI[2][0]) * F0 + std::complex<double>(TI[1][1], TI[2][1]) * F1 +
                      std::complex<double>(TI[1][2], TI[2][2]) * F2 - mc * std::complex<double>(W_[n + r], W_[2 * n + r]);
        }
        solve_real(dWr_.data());
        solve_complex(dWc_.data());
        double acc = 0.0;
        for (int r = 0; r < opt.ne; ++r) {
            const double sc = opt.atol + opt.rtol * (std::abs(z[r]) + mag[r]);
            const double a = dWr_[r] / sc, b = dWc_[r].real() / sc, c = dWc_[r].imag() / sc;
            acc += a * a + b * b + c * c;
        }
        const double dW_norm = std::sqrt(acc / (3 * std::max(opt.ne, 1)));
        if (!std::isfinite(dW_norm)) return false;
        if (dW_norm_old > 0) rate_ = dW_norm / dW_norm_old;
        const double rate = rate_;
        if (rate >= 0 && (rate >= 1 || std::pow(rate, NEWTON_MAXITER - it) / (1 - rate) * dW_norm > newton_tol))
            return false;
        for (int r = 0; r < n; ++r) {
            W_[r] += dWr_[r];
            W_[n + r] += dWc_[r].real();
            W_[2 * n + r] += dWc_[r].imag();
        }
        for (int s = 0; s < 3; ++s)
            for (int r = 0; r < n; ++r) Z_[s * n + r] = T[s][0] * W_[r] + T[s][1] * W_[n + r] + T[s][2] * W_[2 * n + r];
        if (dW_norm == 0 || (rate >= 0 && rate / (1 - rate) * dW_norm < newton_tol)) return true;
        dW_norm_old = dW_norm;
    }
    return false;
}

void Radau::initial_guess(double h) {
    const int n = n_;
    if (have_sol_) {
        for (int s = 0; s < 3; ++s) {
            const double x1 = 1.0 + C[s] * h / h_sol_;
            for (int r = 0; r < n; ++r)
                Z_[s * n + r] = Qd_[r * 3] * (x1 - 1.0) + Qd_[r * 3 + 1] * (x1 * x1 - 1.0) + Qd_[r * 3 + 2] * (x1 * x1 * x1 - 1.0);
        }
    } else {
        std::fill(Z_.begin(), Z_.end(), 0.0);
    }
    for (int s = 0; s < 3; ++s)
        for (int r = 0; r < n; ++r) W_[s * n + r] = TI[s][0] * Z_[r] + TI[s][1] * Z_[n + r] + TI[s][2] * Z_[2 * n + r];
}

// The embedded error estimate, filtered ([HW] IV.8, eq. 8.20): err = (mu_real/h - J)^-1 (f0 + Z^T E / h).
double Radau::error(double h, const double* z, const double* znew, const double* f0, double* errv, const double* mag,
                    const Options& opt) {
    const int n = n_;
    for (int r = 0; r < n; ++r) errv[r] = f0[r] + (Z_[r] * E[0] + Z_[n + r] * E[1] + Z_[2 * n + r] * E[2]) / h;
    solve_real(errv);
    return scaled_rms(errv, z, znew, mag, opt.ne, opt.rtol, opt.atol);
}

// This step's dense output Qd (also the next step's Newton starting guess).
void Radau::collocation_polynomial(double h) {
    const int n = n_;
    for (int r = 0; r < n; ++r)
        for (int k = 0; k < 3; ++k) Qd_[r * 3 + k] = Z_[r] * P[0][k] + Z_[n + r] * P[1][k] + Z_[2 * n + r] * P[2][k];
    have_sol_ = true, h_sol_ = h;
}

void Radau::dense(Problem&, double, double, double x, const double* z0, const double*, double* out, Stats&) {
    for (int r = 0; r < n_; ++r) out[r] = z0[r] + x * (Qd_[r * 3] + x * (Qd_[r * 3 + 1] + x * Qd_[r * 3 + 2]));
}

std::unique_ptr<AdaptiveStepper> make_radau(int n) { return std::make_unique<Radau>(n); }

}  // namespace core::sim
