// The classical fourth-order Runge-Kutta method, fixed step ([HNW] sec. II.1):
//     k1 = f(t, z),  k2 = f(t + h/2, z + h/2 k1),  k3 = f(t + h/2, z + h/2 k2),  k4 = f(t + h, z + h k3)
//     z+ = z + h/6 (k1 + 2 k2 + 2 k3 + k4)
// k1 is the slope at the end of the previous step (re-expressed in the new chart), so a step costs 3 evaluations
// here plus the end slope the fixed-step driver takes: 4.  Samples between steps: the cubic Hermite interpolant
// of (z, f) at both ends.
#include <vector>

#include "methods.hpp"

namespace core::sim {

namespace {

constexpr double C[4] = {0.0, 0.5, 0.5, 1.0};

class RK4 : public FixedStepper {
public:
    explicit RK4(int n) : n_(n), K_(3 * static_cast<size_t>(n)), zs_(n) {}
    void step(Problem& p, double t, double h, double* z, const double* f0, Stats& st) override {
        for (int s = 0; s < 3; ++s) {
            const double* prev = s == 0 ? f0 : &K_[(s - 1) * n_];
            for (int r = 0; r < n_; ++r) zs_[r] = z[r] + C[s + 1] * h * prev[r];
            p.rhs(t + C[s + 1] * h, zs_.data(), &K_[s * n_]);
        }
        st.rhs_evals += 3;
        for (int r = 0; r < n_; ++r) z[r] += h / 6.0 * (f0[r] + 2.0 * K_[r] + 2.0 * K_[n_ + r] + K_[2 * n_ + r]);
    }
    // the cubic Hermite through (z0, f0) and (z1, f1)
    void dense(double x, double h, const double* z0, const double* f0, const double* z1, const double* f1,
               double* out) override {
        const double h00 = (1 + 2 * x) * ((1 - x) * (1 - x)), h10 = x * ((1 - x) * (1 - x));
        const double h01 = x * x * (3 - 2 * x), h11 = x * x * (x - 1);
        for (int r = 0; r < n_; ++r) out[r] = h00 * z0[r] + h10 * h * f0[r] + h01 * z1[r] + h11 * h * f1[r];
    }

private:
    int n_;
    std::vector<double> K_, zs_;  // (3, n) stages 2-4; the stage state
};

}  // namespace

std::unique_ptr<FixedStepper> make_rk4(int n) { return std::make_unique<RK4>(n); }

}  // namespace core::sim
