// Radau IIA(5) (radau.cpp): declared here for auto.cpp, which wraps it with its switch test.
#pragma once

#include <complex>
#include <vector>

#include "second_order.hpp"
#include "solver.hpp"

namespace core::sim {

class Radau : public AdaptiveStepper {
public:
    explicit Radau(int n);
    bool attempt(Problem& p, double t, double h, const double* z, const double* f0, double* znew, double* fnew,
                 double* errv, const double* mag, const Options& opt, Stats& st, std::vector<Switch>& sw,
                 bool rejected_last, double& h_next) override;
    void dense(Problem& p, double t0, double h, double x, const double* z0, const double* z1, double* out,
               Stats& st) override;
    int order() const override { return 3; }  // for the starting step: the embedded estimate's order
    // Forget the Jacobian, the LU, the controller's memory and the last polynomial (a fresh start, or auto switching
    // to this method).
    void reset();
    double rho() const { return rho_; }  // the spectral radius of the last Jacobian (< 0: none yet)

private:
    void factor(double h, Stats& st);
    void solve_real(double* b);
    void solve_complex(std::complex<double>* b);
    bool newton(Problem& p, double t, double h, const double* z, const double* mag, const Options& opt, Stats& st);
    void initial_guess(double h);
    double error(double h, const double* z, const double* znew, const double* f0, double* errv, const double* mag,
                 const Options& opt);
    void collocation_polynomial(double h);

    int n_;
    std::vector<double> J_, LUr_;                 // (n, n): df/dz at the start of the step that computed it; LU
    std::vector<std::complex<double>> LUc_;       // (n, n) complex LU of mu_complex/h - J
    std::vector<int> pivr_, pivc_, envr_, envc_;  // the two LUs' pivots and envelopes
    std::vector<double> Z_, W_, F_, Qd_, zs_, dWr_;  // (3, n) increments, T^-1 Z, f at the stages; (n, 3) dense
    std::vector<std::complex<double>> dWc_;
    // a second-order problem's systems reduced to its velocities (second_order.hpp): the joints' blocks, or null
    const std::vector<int>* blocks_ = nullptr;
    ReducedSystem<double> Sr_;
    ReducedSystem<std::complex<double>> Sc_;
    bool need_jac_, current_jac_, have_lu_, have_sol_;
    double h_sol_, h_abs_old_, err_norm_old_, rho_, rate_ = -1.0;
    int n_iter_ = 0;
};

}  // namespace core::sim
