// The constrained robot as an ODE (constrained_problem.hpp).
#include "constrained_problem.hpp"

#include <algorithm>
#include <cmath>

#include "configuration.hpp"

namespace core::sim {

ConstrainedProblem::ConstrainedProblem(const Model& model, const Constraints& con, const control::Passive& passive,
                                       control::Source& source, const double* q0, const Outputs& out, double alpha,
                                       double beta, bool project, double* out_lam, double* drift,
                                       ContactHooks* contact)
    : RobotProblem(model, passive, source, q0, out, contact), con_(con), alpha_(alpha), beta_(beta),
      project_(project), out_lam_(out_lam), drift_(drift), lam_(con.m), abuf_(model.nv), vbuf_(model.nv),
      qproj_(model.nq) {
    cd_.resize(model, con);
}

void ConstrainedProblem::applied(double t, const double* q, const double* v, const double* delta, double& power_s,
                                 double& power_p, double& power_c) {
    source_and_passive(t, q, v, power_s, power_p);
    power_c = contact_ ? contact_->torques(model_, q, v, tau_p_.data(), delta) : 0.0;
}

// dz = f(t, z): chart rate, the constrained accelerations (NaN when M is singular), powers.
void ConstrainedProblem::rhs(double t, const double* z, double* dz) {
    const double* q = chart_and_velocity(z, dz);
    const double* v = z + nv_;
    double power_s, power_p, power_c;
    applied(t, q, v, z, power_s, power_p, power_c);
    if (constrained_forward_dynamics(model_, con_, data_, cd_, q, v, tau_p_.data(), passive_.gravity, alpha_, beta_,
                                     dz + nv_, lam_.data()) >= 0)
        std::fill(dz + nv_, dz + 2 * nv_, std::nan(""));
    quadratures(dz, power_s, power_p, power_c);
}

void ConstrainedProblem::track_drift(const double* q, const double* v) {
    double position, velocity;
    constraint_drift(model_, con_, data_, cd_, q, v, position, velocity);
    drift_[0] = std::max(drift_[0], position);
    drift_[1] = std::max(drift_[1], velocity);
}

// The robot problem's re-centring, then (project) the projection onto phi = 0, Phi_q v = 0 and f(t, z) again at
// the projected state; then the drift of the state the next step starts from.
void ConstrainedProblem::rebase(double t, double* z, double* dz, double* mag) {
    RobotProblem::rebase(t, z, dz, mag);
    double* v = z + nv_;
    if (project_) {
        const double err = project_position(model_, con_, data_, cd_, base_.data(), PROJECT_TOL, PROJECT_ITER,
                                            qproj_.data());
        if (err <= PROJECT_TOL) {
            std::copy(qproj_.begin(), qproj_.end(), base_.begin());
            if (contact_) contact_->rebased();  // (the clearance's bound follows chart steps, not projections)
        } else {  // keep the step's configuration; the drift and the report say how far off it is
            drift_[2] += 1.0;
        }
        if (project_velocity(model_, con_, data_, cd_, base_.data(), v, vbuf_.data()) < 0)
            std::copy(vbuf_.begin(), vbuf_.end(), v);
        rhs(t, z, dz);
        RobotProblem::rebase(t, z, dz, mag);  // the magnitudes of the projected state (z's chart part is zero)
    }
    track_drift(base_.data(), v);
}

// The robot problem's sample, its drift and, when kept, its multipliers.
void ConstrainedProblem::emit(int64_t j, double t, const double* z) {
    RobotProblem::emit(j, t, z);
    double* q = qbuf_.data();
    retract(model_, base_.data(), z, q);  // the sample's configuration
    const double* v = z + nv_;
    track_drift(q, v);
    if (!out_lam_) return;
    double power_s, power_p, power_c;
    applied(t, q, v, z, power_s, power_p, power_c);
    constrained_forward_dynamics(model_, con_, data_, cd_, q, v, tau_p_.data(), passive_.gravity, alpha_, beta_,
                                 abuf_.data(), out_lam_ + j * con_.m);
}

}  // namespace core::sim
