// What the solvers and the problem say to each other: the problem interface, the stepper interfaces, the named
// options and statistics, and the statuses (the C++ side of dynamics/simulation/solvers/interface.py).
//
// Problem.  The drivers (fixed.cpp, adaptive.cpp) and the steppers reach a problem through this interface: a
// virtual call per right-hand side, nanoseconds against the microseconds of the dynamics (a problem is an object
// the driver calls, not a type the solver is compiled for).
//   rhs(t, z, dz)            dz = f(t, z)
//   rebase(t, z, dz, mag)    after every accepted step (t: the time reached): a problem integrating in a moving
//                            chart folds z's chart coordinates into its base, zeroes them, rewrites dz's chart
//                            part for the new chart, and writes the magnitude of every component for the
//                            relative tolerance
//   euler_config(z, h)       symplectic Euler's configuration update from the (already updated) velocity part
//   emit(j, t, z)            record output sample j at time t (z in the chart of the current step)
//   touchdown()              true once when the last accepted state touches something after touching nothing
//   jacobian(...)            J = df/dz analytically; false: the solvers take finite differences
//   implicit_terms(...)      the linearly implicit Euler's terms (implicit_euler.cpp), without f; false: none
//   aborted()                the problem cannot go on (a Python torque callback raised): the driver stops
// State layout: z = [configuration part (nc), velocity part (nvel), quadratures]; only the first ne components
// enter error norms and Newton tests (the rest are quadratures f does not depend on).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

namespace core::sim {

enum Status : int64_t { OK = 0, NONFINITE = 1, BLOWUP = 2, MAX_STEPS = 3, STEP_TOO_SMALL = 4, SWITCHED = 5,
                        ABORTED = 6, DEADLINE = 7 };
enum SwitchTo : int64_t { TO_RK45 = 0, TO_RADAU = 1 };
enum SwitchReason : int64_t { SWITCH_STIFF = 0, SWITCH_NONSTIFF = 1, SWITCH_CONTACT = 2 };
constexpr int MAX_SWITCHES = 64;

// What a solver is asked to do.
struct Options {
    int nc = 0;             // configuration (chart) components of z
    int nvel = 0;           // velocity components (checked against blowup)
    int ne = 0;             // components under error control (the rest are quadratures)
    int64_t max_steps = 0;  // budget of attempted steps (adaptive)
    int64_t nsteps = 0;     // number of steps (fixed-step methods)
    double dt = 0.0;        // step (fixed-step methods)
    double rtol = 1e-6, atol = 1e-8;
    double h0 = 0.0;    // first step (adaptive; <= 0: Hairer's starting-step heuristic)
    double hmax = 1e300;
    double blowup = 1e6;  // a velocity above this stops the run
    bool probe = false;   // fixed-step methods: first estimate the spectral radius of df/dz at t0 (Stats::rho0)
    double deadline = 1e300;  // seconds of wall time from the start of the run; past it the run stops (DEADLINE)
    // fixed-step methods: f at the end of the last step, for a caller that goes on from there with another
    // right-hand side (false: a simulator's period, whose next period starts under another held torque and
    // evaluates f afresh; a NaN in it is then found at that next start)
    bool end_slope = true;
    // auto: no switch from radau back to rk45 while the accepted state touches something (a simulator's periods cap
    // radau's step, so h rho looks small while the contact is as stiff as ever; rk45 would then crawl at the
    // friction's stability limit, its own stiffness test blind to it)
    bool stay_stiff_in_contact = false;
};

// The solver's statistics: one record, laid out as dynamics.simulation.solvers.STATS (the same field order and
// types: the bindings hand the record to numpy as that dtype).
struct Stats {
    int64_t status = OK, steps = 0, rejected = 0, rhs_evals = 0, jacobian_evals = 0, lu_decompositions = 0,
            switches = 0, stiff_hits = 0;
    int64_t samples = 0;         // output samples written: a resumed run (auto's other method) goes on from here
    int64_t switch_request = 0;  // set by an auto stepper: end the run after this step (status SWITCHED)
    double t, h, local_error = 0.0;
    double stiff_t, h_rho, rho0;  // rk45's stiffness test's first time; radau's largest h rho; rho(df/dz) at t0
    Stats();
};

// One switch of auto: time, method switched to, reason, the measured h |lambda| (dtype SWITCH).
struct Switch {
    double t;
    int64_t to, reason;
    double value;
};

class Problem {
public:
    virtual ~Problem() = default;
    virtual void rhs(double t, const double* z, double* dz) = 0;
    virtual void rebase(double t, double* z, double* dz, double* mag) = 0;
    virtual void euler_config(double* z, double h) = 0;
    virtual void emit(int64_t j, double t, const double* z) = 0;
    virtual bool touchdown() { return false; }
    virtual bool touching() const { return false; }  // the last accepted state touches something
    virtual bool jacobian(double /*t*/, const double* /*z*/, const double* /*f0*/, const double* /*mag*/, int /*ne*/,
                          double* /*J*/, Stats& /*st*/) {
        return false;
    }
    virtual bool aborted() const { return false; }
    // A second-order problem whose implicit solvers may reduce their linear systems to the velocities
    // (second_order.hpp): z = [delta (nv), v (nv), quadratures], the chart rate of each joint's coordinates a
    // function of its own delta and v only.  The first velocity coordinate of each joint, then nv; null: not so.
    virtual const std::vector<int>* second_order_blocks() const { return nullptr; }
    // The linearly implicit Euler's terms at (t, z), z at the start of a step (its chart part zero), in place of f:
    // r = M a, the generalised force the accelerations answer (tau - C v - g + J_c^T f_c); w (n) the quadratures'
    // rates in its components 2 nv and up; M (nv x nv) the mass matrix; D = d tau/dv and K = d tau/dq, the stiff
    // forces' derivatives in tangent coordinates (zero where nothing stiff acts); lam: Featherstone's lambda over
    // the velocity coordinates when every nonzero of M, D and K lies on a path to the root (then only those entries
    // are written), else null.
    // false: the problem has no such form (a generic ODE, closed loops), and the step takes f.
    virtual bool implicit_terms(double /*t*/, const double* /*z*/, double* /*r*/, double* /*w*/, double* /*M*/,
                                double* /*D*/, double* /*K*/, const int*& /*lam*/) {
        return false;
    }
};

// An adaptive method (adaptive.cpp drives it).
class AdaptiveStepper {
public:
    virtual ~AdaptiveStepper() = default;
    // One attempted step of size h from (t, z) with f0 = f(t, z); when accepted it writes znew, fnew = f(t + h,
    // znew) and errv (the local error vector).  Returns whether it was accepted; h_next: the next step size.
    virtual bool attempt(Problem& p, double t, double h, const double* z, const double* f0, double* znew,
                         double* fnew, double* errv, const double* mag, const Options& opt, Stats& st,
                         std::vector<Switch>& sw, bool rejected_last, double& h_next) = 0;
    // The state at t0 + x h of the last accepted step z0 -> z1.
    virtual void dense(Problem& p, double t0, double h, double x, const double* z0, const double* z1, double* out,
                       Stats& st) = 0;
    virtual int order() const = 0;
};

// A fixed-step method (fixed.cpp drives it).
class FixedStepper {
public:
    virtual ~FixedStepper() = default;
    // false: step() is given no f0 (null) and the driver evaluates no slopes (implicit_euler's terms replace them)
    virtual bool needs_slope() const { return true; }
    virtual void step(Problem& p, double t, double h, double* z, const double* f0, Stats& st) = 0;
    virtual void dense(double x, double h, const double* z0, const double* f0, const double* z1, const double* f1,
                       double* out) = 0;
};

// The drivers: integrate z (n components) from t0 to t_end, samples at out_t (T); return the status.
Status solve_fixed(Problem& p, FixedStepper& m, double* z, int n, double t0, double t_end, const double* out_t,
                   int64_t T, const Options& opt, Stats& st);
Status solve_adaptive(Problem& p, AdaptiveStepper& m, double* z, int n, double t0, double t_end, const double* out_t,
                      int64_t T, const Options& opt, Stats& st, std::vector<Switch>& sw);

// A method by name ("euler", "implicit_euler", "rk4", "rk45", "dop853", "radau", "auto") over the problem; auto
// alternates its two phases.  The switch log is appended to sw.
Status run_method(const char* method, Problem& p, double* z, int n, double t0, double t_end, const double* out_t,
                  int64_t T, Options opt, Stats& st, std::vector<Switch>& sw);
// The steppers of a run, kept for the next run of the same problem (a simulator's periods, simulator.hpp): radau
// keeps its Jacobian, its LU and its controller's memory from one period to the next, auto its phase (0: non-stiff,
// rk45; 1: stiff, radau).  A run given an empty one makes its own, as a single run does.
struct Steppers {
    std::unique_ptr<FixedStepper> fixed;
    std::unique_ptr<AdaptiveStepper> adaptive;
    int phase = 0;
    void clear() { fixed.reset(), adaptive.reset(), phase = 0; }
};
Status run_method(const char* method, Problem& p, double* z, int n, double t0, double t_end, const double* out_t,
                  int64_t T, Options opt, Stats& st, std::vector<Switch>& sw, Steppers& keep);

}  // namespace core::sim
