// A method by name over a problem (solver.hpp's run_method): the fixed-step methods through solve_fixed, the
// adaptive ones through solve_adaptive, auto alternating its two phases, each resumed from the time, state, samples
// and statistics the other reached, with the step size it proposed.
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <string>

#include "methods.hpp"

namespace core::sim {

Status run_method(const char* method, Problem& p, double* z, int n, double t0, double t_end, const double* out_t,
                  int64_t T, Options opt, Stats& st, std::vector<Switch>& sw) {
    Steppers fresh;
    return run_method(method, p, z, n, t0, t_end, out_t, T, opt, st, sw, fresh);
}

Status run_method(const char* method, Problem& p, double* z, int n, double t0, double t_end, const double* out_t,
                  int64_t T, Options opt, Stats& st, std::vector<Switch>& sw, Steppers& keep) {
    const std::string m = method;
    if (m == "euler" || m == "rk4" || m == "implicit_euler") {
        if (!keep.fixed)
            keep.fixed = m == "euler" ? make_euler(opt.nc, n)
                         : m == "rk4" ? make_rk4(n)
                                      : make_implicit_euler(opt.nc, n);
        return solve_fixed(p, *keep.fixed, z, n, t0, t_end, out_t, T, opt, st);
    }
    if (m == "rk45" || m == "dop853" || m == "radau") {
        if (!keep.adaptive) keep.adaptive = m == "rk45" ? make_rk45(n) : m == "dop853" ? make_dop853(n) : make_radau(n);
        return solve_adaptive(p, *keep.adaptive, z, n, t0, t_end, out_t, T, opt, st, sw);
    }
    if (m != "auto") throw std::invalid_argument("integrator: unknown method " + m);
    // auto: a fresh stepper for each phase; each phase is given what is left of the deadline
    using clock = std::chrono::steady_clock;
    const auto start = clock::now();
    const double deadline = opt.deadline;
    bool stiff = keep.phase != 0;
    while (true) {
        if (!keep.adaptive) keep.adaptive = stiff ? make_auto_radau(n) : make_auto_rk45(n);
        opt.deadline = deadline - std::chrono::duration<double>(clock::now() - start).count();
        const Status status = solve_adaptive(p, *keep.adaptive, z, n, t0, t_end, out_t, T, opt, st, sw);
        if (status != SWITCHED) {
            keep.phase = stiff;
            return status;
        }
        stiff = !stiff;
        keep.adaptive.reset();
        t0 = st.t, opt.h0 = st.h;
    }
}

}  // namespace core::sim
