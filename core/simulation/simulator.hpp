// A simulation stepped from the caller's loop (dynamics.Simulator): N environments of one model, each its robot
// problem (its own workspaces, its own contact) advanced one control period at a time under a torque the caller holds
// constant over the period, added to the torque source's.
//
// Each environment keeps its integration state (the chart's base and z = [delta, v, quadratures]) from one period
// to the next, so that stepping a fixed-step method period by period gives the bits of one run sampled at the
// periods.  What the caller reads lives in arrays the caller owns (numpy's): the time, q and v written by the
// problem's sample at the end of each period, the step size and the auto phase carried to the next period, the
// status, the period's error estimate, its work and the energies.  A period that fails (a non-finite or blown-up
// state, a step budget spent, a step too small, a Python torque that raised) leaves the environment as it was at
// the period's start and marks it; a marked environment is not stepped until the caller loads a state into it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "robot_problem.hpp"

namespace core::sim {

// One environment's arrays (rows of the caller's (N, ...) arrays).
struct EnvArrays {
    double* t = nullptr;         // (1,) time
    double* q = nullptr;         // (nq,)
    double* v = nullptr;         // (nv,)
    double* h = nullptr;         // (1,) the adaptive step proposed for the next period (<= 0: Hairer's heuristic)
    int64_t* phase = nullptr;    // (1,) auto's phase: 0 non-stiff (rk45), 1 stiff (radau)
    int64_t* status = nullptr;   // (1,) OK, or why the last period failed (then q, v, t are the period's start)
    double* error = nullptr;     // (1,) the period's error estimate: the embedded local errors summed (NaN: none)
    double* w = nullptr;         // (nquad,) the work of the source, the passive torques (and contact) over the period
    int64_t* count = nullptr;    // (1,) the problem's sample counter
    int64_t* counters = nullptr;  // (4,) steps, rejected steps, right-hand sides, Jacobians: totals since made
    // (2,) the time the state was loaded at and the periods since, as doubles: period k ends at origin + k dt, as a
    // run's samples do (a sum of dt's would move the step sizes by ulps)
    double* clock = nullptr;
};

// How every period is integrated.
struct StepSettings {
    std::string method;    // "euler", "rk4", "rk45", "dop853", "radau", "auto"
    bool fixed = false;    // euler, rk4
    double dt = 0.0;       // the control period
    double substep = 0.0;  // fixed-step methods: the step (each period: ceil(dt / substep) steps, the last one landing)
    Options opt;           // sizes, tolerances, the step budget of one period, blow-up
    // the error estimate's rerun of every period, when the environments have a shadow: half the substep (fixed
    // steps; the difference times 2^p / (2^p - 1), Richardson) or rtol and atol / 32 (adaptive), as simulate's
    bool rerun = false;
    int order = 0;         // p (fixed-step methods)
};

class Environment {
public:
    Environment(std::unique_ptr<RobotProblem> problem, const EnvArrays& a);
    // A second problem of the same environment (its own workspaces and contact) that reruns every period at tighter
    // settings for the error estimate (error_estimate="rerun"): made on the outputs shadow_outputs() gives.
    Outputs shadow_outputs();
    void set_shadow(std::unique_ptr<RobotProblem> shadow);
    // Take q and v from the arrays (the caller moved the state; t, h, phase and clock are read at every step) and
    // clear the status.
    void load();
    // One period under the held torque tau (nv), `seconds` of wall time left; returns the status (DEADLINE: the
    // state left at the period's start, the status array untouched).
    Status step(const StepSettings& s, const double* tau, double seconds);
    bool ready() const { return *a_.status == OK; }

private:
    // The period again on the shadow from the period's start; the error estimate from the two ends.
    double rerun(const StepSettings& s, double t0, double t1, double seconds);

    std::unique_ptr<RobotProblem> p_, shadow_;
    EnvArrays a_;
    int nq_, nv_, n_;
    std::vector<double> z_, z0_, base0_, held_;
    Steppers steppers_;  // the method's, kept from one period to the next (radau's Jacobian and LU)
    Steppers shadow_steppers_;
    std::vector<double> zs_, sq_, sv_, sw_, dq_, st_;  // the shadow's state, its sample (t, q, v, work), a difference
    std::vector<int64_t> scount_;
    double sh_ = 0.0;  // the shadow's carried step
};

// The outcome of stepping a batch.
struct StepOutcome {
    long failed = 0;        // environments that failed in this step
    long skipped = 0;       // environments not stepped: marked by an earlier failure
    bool expired = false;   // the deadline passed: some environments were left at their period's start
};

// Step every environment that is ready on up to nthreads threads (TAU: (N, nv) row-major held torques), `seconds`
// of wall time from now.
StepOutcome step_all(const Model& model, std::vector<Environment>& envs, const StepSettings& s, const double* TAU,
                     int nthreads, double seconds);

}  // namespace core::sim
