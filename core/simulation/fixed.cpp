// The fixed-step driver (euler, rk4): steps of size dt from t0 to t_end, the last one shortened to land on t_end
// exactly, samples from the stepper's interpolant.  The slope at the end of a step serves the interpolant of that
// step and, re-expressed in the new chart by rebase, the first stage of the next one.
#include <chrono>
#include <cmath>
#include <vector>

#include "linalg.hpp"

namespace core::sim {

namespace {

// f(t, z) into f (a slope the stepper needs: the first stage, the interpolant); OK, or why the run stops.
Status slope_at(Problem& p, double t, const double* z, double* f, int n, const Options& opt, Stats& st) {
    p.rhs(t, z, f);
    st.rhs_evals += 1;
    if (state_status(f, n, 0, 0, opt.blowup) == OK) return OK;
    return p.aborted() ? ABORTED : NONFINITE;
}

// Samples j.. in (ta, t] of the step ta -> t (z0 -> z, slopes f0, f1), from the stepper's interpolant; returns the
// next sample's index.
int64_t emit_step(Problem& p, FixedStepper& m, int64_t j, int64_t T, const double* out_t, double ta, double t,
                  const double* z0, const double* f0, const double* z, const double* f1, double* zi) {
    const double h = t - ta;
    for (; j < T && out_t[j] <= t; ++j) {
        if (out_t[j] >= t) {
            p.emit(j, t, z);
        } else {
            m.dense((out_t[j] - ta) / h, h, z0, f0, z, f1, zi);
            p.emit(j, out_t[j], zi);
        }
    }
    return j;
}

// The slope at t0 into f0 when the stepper needs slopes, and the stability probe (Stats::rho0) when asked; OK, or
// NONFINITE when f(t0, z0) is not finite.
Status first_slope(Problem& p, bool slope, double t0, const double* z, double* f0, int n, const Options& opt,
                   Stats& st) {
    if (!slope) return OK;  // (implicit_euler: no slopes; a non-finite state is found after its step)
    if (slope_at(p, t0, z, f0, n, opt, st) != OK) return NONFINITE;
    if (opt.probe) st.rho0 = jacobian_spectral_radius(p, t0, z, f0, n, opt.ne);
    return OK;
}

// Whether step i (ending at t, samples from j on) needs f at its end: the next step's first stage, or the
// interpolant of samples inside it, or the caller's (Options::end_slope).
bool end_slope_needed(const Options& opt, int64_t i, int64_t j, int64_t T, const double* out_t, double t) {
    return opt.end_slope || i < opt.nsteps - 1 || (j < T && out_t[j] < t);
}

}  // namespace

Status solve_fixed(Problem& p, FixedStepper& m, double* z, int n, double t0, double t_end, const double* out_t,
                   int64_t T, const Options& opt, Stats& st) {
    using clock = std::chrono::steady_clock;
    const auto start = clock::now();
    std::vector<double> buf(4 * static_cast<size_t>(n));
    double *mag = buf.data(), *f0 = mag + n, *f1 = f0 + n, *z0 = f1 + n;
    std::vector<double> zi(n);
    const bool slope = m.needs_slope();
    Status status = first_slope(p, slope, t0, z, f0, n, opt, st);
    int64_t j = 0;
    for (; j < T && out_t[j] <= t0; ++j) p.emit(j, t0, z);  // the initial state, also when f(t0, z0) is not finite
    double t = t0;
    for (int64_t i = 0; i < (status == OK ? opt.nsteps : 0); ++i) {
        const double ta = t;  // this step: from ta to t
        t = i == opt.nsteps - 1 ? t_end : std::min(t0 + (i + 1) * opt.dt, t_end);
        std::copy(z, z + n, z0);
        m.step(p, ta, t - ta, z, slope ? f0 : nullptr, st);
        st.steps += 1;
        status = p.aborted() ? ABORTED : state_status(z, n, opt.nc, opt.nvel, opt.blowup);
        if (status != OK) break;
        if (slope && end_slope_needed(opt, i, j, T, out_t, t)) {
            status = slope_at(p, t, z, f1, n, opt, st);
            if (status != OK) break;
        }
        j = emit_step(p, m, j, T, out_t, ta, t, z0, f0, z, f1, zi.data());
        p.rebase(t, z, f1, mag);
        std::copy(f1, f1 + n, f0);
        if ((i & 63) == 63 && std::chrono::duration<double>(clock::now() - start).count() > opt.deadline) {
            status = DEADLINE;
            break;
        }
    }
    st.status = status;
    st.t = t;
    st.h = opt.dt;
    st.local_error = std::nan("");  // fixed-step methods have no embedded error estimate
    st.samples = j;
    return status;
}

}  // namespace core::sim
