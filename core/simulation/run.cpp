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
    int phase = 0;
    return run_method(method, p, z, n, t0, t_end, out_t, T, opt, st, sw, phase);
}

Status run_method(const char* method, Problem& p, double* z, int n, double t0, double t_end, const double* out_t,
                  int64_t T, Options opt, Stats& st, std::vector<Switch>& sw, int& phase) {
    const std::string m = method;
    if (m == "euler") return solve_fixed(p, *make_euler(opt.nc, n), z, n, t0, t_end, out_t, T, opt, st);
    if (m == "rk4") return solve_fixed(p, *make_rk4(n), z, n, t0, t_end, out_t, T, opt, st);
    if (m == "rk45") return solve_adaptive(p, *make_rk45(n), z, n, t0, t_end, out_t, T, opt, st, sw);
    if (m == "dop853") return solve_adaptive(p, *make_dop853(n), z, n, t0, t_end, out_t, T, opt, st, sw);
    if (m == "radau") return solve_adaptive(p, *make_radau(n), z, n, t0, t_end, out_t, T, opt, st, sw);
    if (m != "auto") throw std::invalid_argument("integrator: unknown method " + m);
    // auto: a fresh stepper for each phase; each phase is given what is left of the deadline
    using clock = std::chrono::steady_clock;
    const auto start = clock::now();
    const double deadline = opt.deadline;
    bool stiff = phase != 0;
    while (true) {
        auto stepper = stiff ? make_auto_radau(n) : make_auto_rk45(n);
        opt.deadline = deadline - std::chrono::duration<double>(clock::now() - start).count();
        const Status status = solve_adaptive(p, *stepper, z, n, t0, t_end, out_t, T, opt, st, sw);
        if (status != SWITCHED) {
            phase = stiff;
            return status;
        }
        stiff = !stiff;
        t0 = st.t, opt.h0 = st.h;
    }
}

}  // namespace core::sim
