// A simulation stepped from the caller's loop (simulator.hpp).
#include "simulator.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

#include "configuration.hpp"
#include "parallel.hpp"

namespace core::sim {

Environment::Environment(std::unique_ptr<RobotProblem> problem, const EnvArrays& a)
    : p_(std::move(problem)), a_(a), nq_(p_->model().nq), nv_(p_->model().nv), n_(2 * nv_ + p_->nquad()),
      z_(n_, 0.0), z0_(n_), base0_(nq_), held_(nv_, 0.0) {
    p_->hold(held_.data());
    load();
}

Outputs Environment::shadow_outputs() {
    zs_.resize(n_), sq_.resize(nq_), sv_.resize(nv_), sw_.resize(n_ - 2 * nv_), dq_.resize(nv_), st_.resize(1);
    scount_.resize(1);
    Outputs out;
    out.t = st_.data(), out.T = 1, out.q = sq_.data(), out.v = sv_.data(), out.keep_q = true, out.keep_v = true;
    out.w = sw_.data(), out.count = scount_.data();
    return out;
}

void Environment::set_shadow(std::unique_ptr<RobotProblem> shadow) {
    shadow_ = std::move(shadow);
    shadow_->hold(held_.data());
}

void Environment::load() {
    std::copy(a_.q, a_.q + nq_, p_->base());
    std::fill(z_.begin(), z_.end(), 0.0);
    std::copy(a_.v, a_.v + nv_, z_.begin() + nv_);
    *a_.status = OK;
    steppers_.clear(), shadow_steppers_.clear(), sh_ = 0.0;
    p_->restart();
    if (shadow_) shadow_->restart();
}

double Environment::rerun(const StepSettings& s, double t0, double t1, double seconds) {
    std::copy(base0_.begin(), base0_.end(), shadow_->base());
    zs_ = z0_;
    Options opt = s.opt;
    opt.deadline = seconds, opt.end_slope = false, opt.stay_stiff_in_contact = true;
    if (s.fixed) {
        opt.dt = s.substep / 2;
        opt.nsteps = std::max<int64_t>(1, static_cast<int64_t>(std::ceil(s.dt / opt.dt * (1 - 1e-12))));
        opt.max_steps = std::max(opt.max_steps, opt.nsteps);
    } else {
        opt.rtol = std::max(opt.rtol / 32, 1e-14), opt.atol /= 32, opt.h0 = sh_, opt.max_steps *= 4;
    }
    Stats st;
    std::vector<Switch> sw;
    scount_[0] = 0;
    const Status status = run_method(s.method.c_str(), *shadow_, zs_.data(), n_, t0, t1, &t1, 1, opt, st, sw,
                                     shadow_steppers_);
    a_.counters[0] += st.steps, a_.counters[1] += st.rejected, a_.counters[2] += st.rhs_evals;  // its cost too
    a_.counters[3] += st.jacobian_evals;
    if (status != OK || scount_[0] != 1) {
        shadow_steppers_.clear(), sh_ = 0.0;
        shadow_->restart();
        return INFINITY;
    }
    sh_ = st.h;
    difference(p_->model(), sq_.data(), a_.q, dq_.data());  // the shadow's sample and the period's: q, v at t1
    double err = 0.0;
    for (int k = 0; k < nv_; ++k) err = std::max({err, std::abs(dq_[k]), std::abs(a_.v[k] - sv_[k])});
    const double richardson = s.fixed ? std::ldexp(1.0, s.order) / (std::ldexp(1.0, s.order) - 1.0) : 1.0;
    return err * richardson;
}

// One period: the run of the method from (t, z) to t + dt with one sample at its end (the arrays' t, q, v, work,
// energies); on failure the state of the period's start again.
Status Environment::step(const StepSettings& s, const double* tau, double seconds) {
    std::copy(tau, tau + nv_, held_.begin());
    std::fill(z_.begin() + 2 * nv_, z_.end(), 0.0);  // the period's work, from zero
    std::copy(p_->base(), p_->base() + nq_, base0_.begin());
    z0_ = z_;
    const double t0 = *a_.t, t1 = a_.clock[0] + (a_.clock[1] + 1.0) * s.dt;
    Options opt = s.opt;
    opt.deadline = seconds;
    opt.end_slope = false;  // the next period evaluates f afresh under its own held torque
    opt.stay_stiff_in_contact = true;
    if (s.fixed) {
        opt.dt = s.substep;
        opt.nsteps = std::max<int64_t>(1, static_cast<int64_t>(std::ceil(s.dt / s.substep * (1 - 1e-12))));
    } else {
        opt.h0 = *a_.h;
    }
    Stats st;
    std::vector<Switch> sw;
    if (steppers_.phase != *a_.phase) steppers_.clear(), steppers_.phase = static_cast<int>(*a_.phase);
    *a_.count = 0;
    Status status = run_method(s.method.c_str(), *p_, z_.data(), n_, t0, t1, &t1, 1, opt, st, sw, steppers_);
    a_.counters[0] += st.steps, a_.counters[1] += st.rejected, a_.counters[2] += st.rhs_evals;
    a_.counters[3] += st.jacobian_evals;
    if (status == OK && *a_.count == 1) {
        *a_.h = st.h, *a_.phase = steppers_.phase, a_.clock[1] += 1.0;
        *a_.error = shadow_ ? rerun(s, t0, t1, seconds) : s.fixed ? std::nan("") : st.local_error;
        return OK;
    }
    if (status == OK) status = NONFINITE;  // (a run that ends OK has written its sample)
    std::copy(base0_.begin(), base0_.end(), p_->base());
    z_ = z0_;
    steppers_.clear();
    p_->restart();
    if (status != DEADLINE) *a_.status = status;
    return status;
}

StepOutcome step_all(const Model& model, std::vector<Environment>& envs, const StepSettings& s, const double* TAU,
                     int nthreads, double seconds) {
    using clock = std::chrono::steady_clock;
    const auto start = clock::now();
    const long N = static_cast<long>(envs.size());
    std::atomic<long> failed{0}, skipped{0}, expired{0};
    auto one = [&](long i) {
        Environment& env = envs[i];
        if (!env.ready()) {
            skipped.fetch_add(1, std::memory_order_relaxed);
            return -1;
        }
        const double left = seconds - std::chrono::duration<double>(clock::now() - start).count();
        if (left <= 0) {  // past the deadline: not started (a period of one fixed step never looks at the clock)
            expired.fetch_add(1, std::memory_order_relaxed);
            return -1;
        }
        const Status status = env.step(s, TAU + i * model.nv, left);
        if (status == DEADLINE) {
            expired.fetch_add(1, std::memory_order_relaxed);
        } else if (status != OK) {
            failed.fetch_add(1, std::memory_order_relaxed);
        }
        return -1;  // a failed environment does not stop the others
    };
    if (N == 1 || nthreads <= 1) {  // on this thread, without the batch's workspaces (a microsecond per step)
        for (long i = 0; i < N; ++i) one(i);
        return StepOutcome{failed.load(), skipped.load(), expired.load() > 0};
    }
    // a period weighs many states' dynamics: two environments are worth a thread, and small chunks balance them
    const long chunk = std::max(1L, std::min(CHUNK, N / (4L * std::max(1, nthreads))));
    const BatchStatus b = run_batch(model, N, nthreads, seconds, [&](long i, Data&) { return one(i); }, 2, chunk);
    return StepOutcome{failed.load(), skipped.load(), b.expired || expired.load() > 0};
}

}  // namespace core::sim
