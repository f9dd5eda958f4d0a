// Forward sensitivities of a simulation: S(t) = dx(t)/d(x0, p), integrated with the state under the same error
// control (simulate(..., sensitivities=...); dynamics/simulation/sensitivities.py has the derivation).
//
// With x = (q, v) and the robot's ODE x' = f(t, x, p), S obeys the variational equations
//     S' = df/dx(t, x(t)) S + df/dp(t, x(t)),      S(0) = [I_2nv | 0]  (columns: x0, then the parameters p)
// (Hairer, Norsett & Wanner I, sec. I.14), appended to the state: z = [delta, v, S column by column, quadratures].
// The explicit methods integrate S with the state's own stages, and every component of S enters the error norm.
// Radau's Newton matrix for the augmented system is block diagonal, diag(J, J, ..., J) (CVODES' simultaneous
// corrector).  df/dp: the right-hand side differenced in the parameter (central differences of a function affine in
// each supported parameter: exact but for rounding).  Inside the run S's q-rows are chart rows; with C(q, delta) =
// d delta / d e for the tangent displacement e at q = retract(base, delta), S0 = C(q0, 0) on the q0 columns,
// S_tangent = C(q, delta)^-1 S_chart at a sample, and S <- C(q1, 0) C(q1, delta1)^-1 S at a re-centring.
#pragma once

#include <vector>

#include "robot_problem.hpp"

namespace core::sim {

enum ParameterPlace { GAINS = 0, QREF = 1, TABLE = 2 };  // where a parameter lives in the torque source

class SensitivityProblem : public Problem {
public:
    // S with respect to x0 (x0) and to the parameters (P rows of (place, row, column)); S per sample into out_S
    // ((T, 2 nv, ncol) or null) and at the last re-centring into Sf (2 nv, ncol).
    SensitivityProblem(RobotProblem& inner, bool x0, std::vector<int> params, double* out_S, double* Sf);
    void rhs(double t, const double* z, double* dz) override;
    void rebase(double t, double* z, double* dz, double* mag) override;
    void euler_config(double*, double) override {}
    void emit(int64_t j, double t, const double* z) override;
    bool touchdown() override { return inner_.touchdown(); }
    bool jacobian(double t, const double* z, const double* f0, const double* mag, int ne, double* J, Stats& st) override;
    bool aborted() const override { return inner_.aborted(); }
    int size() const { return n2_ + n2_ * ncol_ + nquad_; }
    // z0 = [0, v0, S0 column by column, 0...]
    void initial_state(const double* v0, double* z) const;
    // S (2 nv, ncol) at the end of a run, tangent q-rows, into S
    void final(const double* z, double* S) const;

private:
    void split(const double* z);
    void join(const double* fi, double* dz) const;
    double* parameter(int j);
    void parameter_derivatives(double t);
    void chart_matrix(const double* q, const double* delta, double* C) const;
    void rows_to_tangent(double* C, const double* z, int o, double* S);

    RobotProblem& inner_;
    const Model& model_;
    int nv_, n2_, nquad_, nx_, ncol_;
    std::vector<int> params_;  // (P, 3)
    double *out_S_, *Sf_;
    std::vector<double> zi_, fi_, fp_, fm_, magi_, J_, B_, C_, col_, delta_;
    std::vector<int> piv_;
    Stats jst_;  // the Jacobian evaluations of the variational equations (not the run's)
};

}  // namespace core::sim
