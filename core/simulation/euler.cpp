// Semi-implicit (symplectic) Euler, first order, fixed step: v+ = v + h a(q, v), then q+ = q (+) h v+ (the
// configuration moves with the new velocity, which keeps the energy of conservative systems bounded); the
// quadratures by explicit Euler.  Samples between steps: linear interpolation.
#include "methods.hpp"

namespace core::sim {

namespace {

class Euler : public FixedStepper {
public:
    Euler(int nc, int n) : nc_(nc), n_(n) {}
    void step(Problem& p, double, double h, double* z, const double* f0, Stats&) override {
        for (int r = nc_; r < n_; ++r) z[r] += h * f0[r];
        p.euler_config(z, h);
    }
    void dense(double x, double, const double* z0, const double*, const double* z1, const double*,
               double* out) override {
        for (int r = 0; r < n_; ++r) out[r] = z0[r] + x * (z1[r] - z0[r]);
    }

private:
    int nc_, n_;
};

}  // namespace

std::unique_ptr<FixedStepper> make_euler(int nc, int n) { return std::make_unique<Euler>(nc, n); }

}  // namespace core::sim
