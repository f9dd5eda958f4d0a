// The adaptive driver: step-size bookkeeping, output sampling from dense output, chart re-centring.  The method
// (rk45, dop853, radau or auto) decides whether an attempted step is accepted and proposes the next step size;
// the driver does what every method shares: the first step (Hairer's heuristic), the step budget, the smallest
// representable step, landing on t_end exactly, the state checks, the samples in each accepted step, and the
// re-centring of the chart after it.  Over ~80 lines: the one loop every adaptive method shares, kept whole.
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "linalg.hpp"

namespace core::sim {

namespace {

// Emit the samples in (t - h, t] from the dense output of the step zold -> z (h = 0: the state at t).
int64_t emit_samples(Problem& p, AdaptiveStepper& m, int64_t j, const double* out_t, int64_t T, double t, double h,
                     const double* zold, const double* z, double* zi, Stats& st) {
    for (; j < T && out_t[j] <= t; ++j) {
        if (out_t[j] >= t || h == 0.0) {
            p.emit(j, t, z);
        } else {
            m.dense(p, t - h, h, (out_t[j] - (t - h)) / h, zold, z, zi, st);
            p.emit(j, out_t[j], zi);
        }
    }
    return j;
}

}  // namespace

Status solve_adaptive(Problem& p, AdaptiveStepper& m, double* z, int n, double t0, double t_end, const double* out_t,
                      int64_t T, const Options& opt, Stats& st, std::vector<Switch>& sw) {
    using clock = std::chrono::steady_clock;
    const auto start = clock::now();
    st.switch_request = 0;
    std::vector<double> buf(7 * static_cast<size_t>(n));
    double *mag = buf.data(), *f0 = mag + n, *fnew = f0 + n, *znew = fnew + n, *zold = znew + n, *errv = zold + n;
    double* zi = errv + n;
    p.rebase(t0, z, f0, mag);  // magnitudes of the initial state (z's chart part is zero)
    p.rhs(t0, z, f0);
    st.rhs_evals += 1;
    Status status = state_status(f0, n, 0, 0, opt.blowup);
    double t = t0;
    // the initial state, also when f(t0, z0) is not finite (a resumed run: its samples so far are written, and the
    // next one is later than t0)
    int64_t j = emit_samples(p, m, st.samples, out_t, T, t, 0.0, zold, z, zi, st);
    double h = opt.h0;
    if (h <= 0) h = initial_step(p, t, z, f0, n, m.order(), opt.rtol, opt.atol, mag, opt.ne, t_end, st);
    h = std::min(h, opt.hmax);
    double local_err = st.local_error;  // a resumed run adds to the first part's sums
    int64_t total = st.steps + st.rejected;
    bool rejected_last = false;
    while (status == OK && t < t_end) {
        if (total >= opt.max_steps) {
            status = MAX_STEPS;
            break;
        }
        const double min_step = 10.0 * std::abs(std::nextafter(t, std::numeric_limits<double>::infinity()) - t);
        if (h < min_step) {
            status = STEP_TOO_SMALL;
            break;
        }
        h = std::min(h, opt.hmax);
        double tn = t + h;
        if (tn >= t_end || t_end - tn < min_step) tn = t_end;
        h = tn - t;
        total += 1;
        double hnew;
        const bool accepted = m.attempt(p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last, hnew);
        if (p.aborted()) {
            status = ABORTED;
            break;
        }
        if ((total & 15) == 0 && std::chrono::duration<double>(clock::now() - start).count() > opt.deadline) {
            status = DEADLINE;
            break;
        }
        rejected_last = !accepted;
        if (!accepted) {
            st.rejected += 1;
            h = hnew;
            continue;
        }
        st.steps += 1;
        local_err += max_abs(errv, opt.ne);
        std::copy(z, z + n, zold);
        std::copy(znew, znew + n, z);
        std::copy(fnew, fnew + n, f0);
        t = tn;
        status = state_status(z, n, opt.nc, opt.nvel, opt.blowup);
        if (status != OK) break;
        j = emit_samples(p, m, j, out_t, T, t, h, zold, z, zi, st);
        p.rebase(t, z, f0, mag);  // re-centre the chart; f0 = f(t, z) in the new chart
        h = hnew;
        if (st.switch_request) {  // auto changes method here: the caller resumes from (t, z) with h
            status = SWITCHED;
            break;
        }
    }
    st.status = status;
    st.samples = j;
    st.t = t;
    st.local_error = local_err;
    st.h = h;
    return status;
}

}  // namespace core::sim
