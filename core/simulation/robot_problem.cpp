// The robot as an ODE (robot_problem.hpp).
#include "robot_problem.hpp"

#include <algorithm>
#include <cmath>

#include "aba.hpp"
#include "configuration.hpp"
#include "control/passive.hpp"
#include "energy.hpp"

namespace core::sim {

RobotProblem::RobotProblem(const Model& model, const control::Passive& passive, control::Source& source,
                           const double* q0, const Outputs& out, ContactHooks* contact)
    : model_(model), passive_(passive), source_(source), ws_source_(model, source.kind), contact_(contact), out_(out),
      nv_(model.nv), nquad_(contact ? 3 : 2), base_(q0, q0 + model.nq), qbuf_(model.nq), tau_s_(model.nv),
      tau_p_(model.nv), pooled_data_(from_pool<Data>()), data_(*pooled_data_) {
    data_.resize(model);
    for (int i = 0; i < model.nb; ++i)
        if (model.nv_j[i] > 0) blocks_.push_back(model.v_idx[i]);
    std::sort(blocks_.begin(), blocks_.end());
    blocks_.push_back(model.nv);
}

const double* RobotProblem::chart_and_velocity(const double* z, double* dz) {
    retract(model_, base_.data(), z, qbuf_.data());
    chart_rate(model_, qbuf_.data(), z, z + nv_, dz);
    return qbuf_.data();
}

void RobotProblem::source_at(double t, const double* q, const double* v, double* tau) {
    control::source_torques(model_, source_, passive_, ws_source_, t, q, v, tau);
    if (held_)
        for (int k = 0; k < nv_; ++k) tau[k] += held_[k];
}

void RobotProblem::source_and_passive(double t, const double* q, const double* v, double& power_s, double& power_p) {
    source_at(t, q, v, tau_s_.data());
    control::passive_torques(passive_, q, v, nv_, tau_p_.data());
    power_s = 0.0, power_p = 0.0;
    for (int k = 0; k < nv_; ++k) {
        power_s += v[k] * tau_s_[k];
        power_p += v[k] * tau_p_[k];
        tau_p_[k] += tau_s_[k];
    }
    abort_if_failed();
}

// A Python torque that raised keeps its error and the run stops (the bindings raise it after the run).
void RobotProblem::abort_if_failed() {
    if (source_.kind == control::CALLABLE && source_.callback->failed()) aborted_ = true;
}

void RobotProblem::quadratures(double* dz, double power_s, double power_p, double power_c) const {
    dz[2 * nv_] = power_s;
    dz[2 * nv_ + 1] = power_p;
    if (nquad_ > 2) dz[2 * nv_ + 2] = power_c;
}

// dz = f(t, z): chart rate, ABA accelerations (NaN when the articulated inertia is singular), powers.  The contact
// forces enter the ABA as external body forces between its first pass and the others: the same accelerations,
// without passes of their own.
void RobotProblem::rhs(double t, const double* z, double* dz) {
    const double* q = chart_and_velocity(z, dz);
    const double* v = z + nv_;
    double power_s, power_p, power_c = 0.0;
    source_and_passive(t, q, v, power_s, power_p);
    aba_rigid_body_pass(model_, data_, q, v, nullptr, true);
    if (contact_) power_c = contact_->bias(model_, data_, q, v, z);
    if (aba_articulated_pass(model_, data_, tau_p_.data()) >= 0) {
        std::fill(dz + nv_, dz + 2 * nv_, std::nan(""));
    } else {
        aba_acceleration_pass(model_, data_, passive_.gravity, dz + nv_);
    }
    quadratures(dz, power_s, power_p, power_c);
}

// Fold the chart coordinates into base, rewrite dz's chart part for the new chart, and the magnitudes of the state
// for the relative tolerance.
void RobotProblem::rebase(double t, double* z, double* dz, double* mag) {
    retract(model_, base_.data(), z, qbuf_.data());
    std::copy(qbuf_.begin(), qbuf_.end(), base_.begin());
    if (contact_) contact_->track(t, base_.data(), z + nv_, z);  // (z's chart part: the step's delta)
    std::fill(z, z + nv_, 0.0);
    chart_rate(model_, base_.data(), z, z + nv_, dz);
    magnitudes(model_, base_.data(), mag);
    const int n = 2 * nv_ + nquad_;
    std::fill(mag + nv_, mag + n, 0.0);
}

void RobotProblem::euler_config(double* z, double h) { integrate_delta(model_, base_.data(), z + nv_, h, z); }

// Write sample j and its energies.
void RobotProblem::emit(int64_t j, double t, const double* z) {
    out_.t[j] = t;
    double* q = out_.keep_q ? out_.q + j * model_.nq : qbuf_.data();  // qbuf is free between right-hand sides
    retract(model_, base_.data(), z, q);
    const double* v = z + nv_;
    if (out_.keep_v) std::copy(v, v + nv_, out_.v + j * nv_);
    if (out_.keep_tau) source_at(t, q, v, out_.tau + j * nv_);
    if (contact_) contact_->emit(j, q, v);
    std::copy(z + 2 * nv_, z + 2 * nv_ + nquad_, out_.w + j * nquad_);
    if (out_.e) energies(model_, data_, q, v, passive_.gravity, true, true, out_.e[2 * j], out_.e[2 * j + 1]);
    __atomic_store_n(out_.count, j + 1, __ATOMIC_RELEASE);
}

}  // namespace core::sim
