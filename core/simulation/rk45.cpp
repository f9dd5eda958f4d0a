// Dormand & Prince 5(4) with local extrapolation, FSAL, the PI step-size controller of DOPRI5 ([HNW] sec. IV.2,
// beta = 0.04), Shampine's quartic dense output, and DOPRI5's stiffness test ([HW] sec. IV.2: h |lambda| estimated
// from the last two stages exceeds 3.25 on 15 accepted steps).
// [HNW] = Hairer, Norsett & Wanner, "Solving ODEs I", 2nd ed. 1993; [HW] = Hairer & Wanner, "Solving ODEs II".
#include <algorithm>
#include <cmath>
#include <vector>

#include "linalg.hpp"
#include "methods.hpp"
#include "rk45.hpp"

namespace core::sim {

namespace {

// the Dormand-Prince 5(4) tableau with the weights as 7th row (the last stage is the new point: FSAL), the error
// weights and Shampine's dense-output polynomial ([HNW] table II.5.2; Shampine 1986)
constexpr double A7[7][6] = {
    {0, 0, 0, 0, 0, 0},
    {1.0 / 5, 0, 0, 0, 0, 0},
    {3.0 / 40, 9.0 / 40, 0, 0, 0, 0},
    {44.0 / 45, -56.0 / 15, 32.0 / 9, 0, 0, 0},
    {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729, 0, 0},
    {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656, 0},
    {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84}};
constexpr double C7[7] = {0.0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1.0, 1.0};
constexpr double E[7] = {-71.0 / 57600, 0, 71.0 / 16695, -71.0 / 1920, 17253.0 / 339200, -22.0 / 525, 1.0 / 40};
constexpr double P[7][4] = {
    {1, -8048581381.0 / 2820520608, 8663915743.0 / 2820520608, -12715105075.0 / 11282082432},
    {0, 0, 0, 0},
    {0, 131558114200.0 / 32700410799, -68118460800.0 / 10900136933, 87487479700.0 / 32700410799},
    {0, -1754552775.0 / 470086768, 14199869525.0 / 1410260304, -10690763975.0 / 1880347072},
    {0, 127303824393.0 / 49829197408, -318862633887.0 / 49829197408, 701980252875.0 / 199316789632},
    {0, -282668133.0 / 205662961, 2019193451.0 / 616988883, -1453857185.0 / 822651844},
    {0, 40617522.0 / 29380423, -110615467.0 / 29380423, 69997945.0 / 29380423}};
constexpr double STIFF_HLAMBDA = 3.25;
constexpr int STIFF_STEPS = 15;

}  // namespace

RK45::RK45(int n) : n_(n), K_(7 * static_cast<size_t>(n)), y6_(n) { reset(); }

void RK45::reset() {
    errold_ = 1e-4;
    iasti_ = nonsti_ = 0;
}

bool RK45::attempt(Problem& p, double t, double h, const double* z, const double* f0, double* znew, double* fnew,
                   double* errv, const double* mag, const Options& opt, Stats& st, std::vector<Switch>&,
                   bool rejected_last, double& h_next) {
    const int n = n_;
    double* K = K_.data();
    std::copy(f0, f0 + n, K);
    for (int s = 1; s < 7; ++s) {
        for (int r = 0; r < n; ++r) {
            double acc = 0.0;
            for (int q = 0; q < s; ++q) acc += A7[s][q] * K[q * n + r];
            znew[r] = z[r] + h * acc;
        }
        if (s == 5) std::copy(znew, znew + n, y6_.data());
        p.rhs(t + C7[s] * h, znew, K + s * n);
    }
    st.rhs_evals += 6;
    for (int r = 0; r < n; ++r) {
        double acc = 0.0;
        for (int q = 0; q < 7; ++q) acc += E[q] * K[q * n + r];
        errv[r] = h * acc;
    }
    const double err = scaled_rms(errv, z, znew, mag, opt.ne, opt.rtol, opt.atol);
    stiff_event_ = false;
    if (!std::isfinite(err) || state_status(K + 6 * n, n, 0, 0, INFINITY) != OK) {
        h_next = h * 0.1;
        return false;
    }
    const double fac11 = std::pow(err, 0.2 - 0.04 * 0.75);  // PI control ([HNW] IV.2, DOPRI5 with beta = 0.04)
    if (err > 1.0) {
        h_next = h / std::min(5.0, fac11 / 0.9);
        return false;
    }
    const double fac = std::max(0.1, std::min(5.0, fac11 / std::pow(errold_, 0.04) / 0.9));  // 1/fac in [0.2, 10]
    errold_ = std::max(err, 1e-4);
    h_next = rejected_last ? std::min(h / fac, h) : h / fac;
    std::copy(K + 6 * n, K + 7 * n, fnew);
    stiffness_test(h, znew, opt.ne, t + h, st);
    return true;
}

// DOPRI5's test: h |lambda| ~ h ||k7 - k6|| / ||y7 - y6|| above 3.25 on 15 accepted steps (6 steps below reset the
// count); sets stiff_event_ on the 15th.
void RK45::stiffness_test(double h, const double* znew, int ne, double tn, Stats& st) {
    const int n = n_;
    const double* K = K_.data();
    double stnum = 0.0, stden = 0.0;
    for (int r = 0; r < ne; ++r) {
        const double a = K[6 * n + r] - K[5 * n + r], b = znew[r] - y6_[r];
        stnum += a * a;
        stden += b * b;
    }
    if (stden <= 0.0) return;
    const double hlamb = h * std::sqrt(stnum / stden);
    if (hlamb > STIFF_HLAMBDA) {
        nonsti_ = 0;
        iasti_ += 1;
        st.stiff_hits += 1;
        if (iasti_ == STIFF_STEPS) {
            stiff_event_ = true;
            hlamb_ = hlamb;
            if (!(st.stiff_t >= 0)) st.stiff_t = tn;
        }
    } else {
        nonsti_ += 1;
        if (nonsti_ == 6) iasti_ = 0;
    }
}

// Shampine's quartic through the stages of the last accepted step.
void RK45::dense(Problem&, double, double h, double x, const double* z0, const double*, double* out, Stats&) {
    const int n = n_;
    const double* K = K_.data();
    double b[7];
    for (int k = 0; k < 7; ++k) b[k] = x * (P[k][0] + x * (P[k][1] + x * (P[k][2] + x * P[k][3])));
    for (int r = 0; r < n; ++r)
        out[r] = z0[r] + h * (b[0] * K[r] + b[2] * K[2 * n + r] + b[3] * K[3 * n + r] + b[4] * K[4 * n + r] +
                              b[5] * K[5 * n + r] + b[6] * K[6 * n + r]);
}

std::unique_ptr<AdaptiveStepper> make_rk45(int n) { return std::make_unique<RK45>(n); }

}  // namespace core::sim
