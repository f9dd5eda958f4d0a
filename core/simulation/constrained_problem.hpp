// A constrained robot (closed loops, coupled joints) as an ODE for the solvers (the C++ side of
// dynamics/simulation/constrained_problem.py): the robot problem with the ABA of the right-hand side replaced by
// the KKT solve of constrained_dynamics.hpp, with Baumgarte's stabilisation,
//
//     M a + C v + g = tau + Phi_q^T lambda,    Phi_q a + Phi_q_dot v = -(2 alpha Phi_q v + beta^2 phi),
//
// and the largest position and velocity residuals (max |phi|, max |Phi_q v|) tracked at every accepted step and
// every sample: the report's constraint_drift.  With "lambda" kept, the multipliers of each sample (those the
// simulation applies there, Baumgarte's terms included).  With `project`, after every accepted step the state is
// moved onto the manifold (positions by Gauss-Newton, project_position; velocities in the kinetic-energy metric,
// project_velocity) and f evaluated again there, so the next step starts on it; a position projection that does
// not reach PROJECT_TOL keeps the step's configuration and is counted.
#pragma once

#include "constrained_dynamics.hpp"
#include "robot_problem.hpp"

namespace core::sim {

//: the position projection stops below this max |phi| (m or rad), after at most PROJECT_ITER steps
constexpr double PROJECT_TOL = 1e-12;
constexpr int PROJECT_ITER = 8;

class ConstrainedProblem : public RobotProblem {
public:
    // out_lam: (T, m) multipliers per sample, or null; drift (3,): the largest max |phi| and max |Phi_q v| seen,
    // and the count of position projections that failed (accumulated into: a resumed run goes on from them).
    ConstrainedProblem(const Model& model, const Constraints& con, const control::Passive& passive,
                       control::Source& source, const double* q0, const Outputs& out, double alpha, double beta,
                       bool project, double* out_lam, double* drift, ContactHooks* contact = nullptr);
    void rhs(double t, const double* z, double* dz) override;
    void rebase(double t, double* z, double* dz, double* mag) override;
    void emit(int64_t j, double t, const double* z) override;
    // No analytical Jacobian (the numba ConstrainedProblem has none either): the solvers difference f.
    // its Jacobian (finite differences of the KKT right-hand side) keeps no velocity structure to reduce to
    const std::vector<int>* second_order_blocks() const override { return nullptr; }
    // the loops' forces are not in the implicit Euler's matrices: it steps as symplectic Euler
    bool implicit_terms(double, const double*, double*, double*, double*, double*, double*, const int*&) override {
        return false;
    }
    bool jacobian(double, const double*, const double*, const double*, int, double*, Stats&) override {
        return false;
    }

private:
    // tau_p = source + passive (+ contact) torques at (t, q, v); their powers.  delta: q's chart coordinate.
    void applied(double t, const double* q, const double* v, const double* delta, double& power_s, double& power_p,
                 double& power_c);
    void track_drift(const double* q, const double* v);

    const Constraints& con_;
    double alpha_, beta_;
    bool project_;
    double *out_lam_, *drift_;
    ConstrainedData cd_;
    std::vector<double> lam_, abuf_, vbuf_, qproj_;
};

}  // namespace core::sim
