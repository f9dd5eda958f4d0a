// Dormand-Prince 5(4) (rk45.cpp): declared here for auto.cpp, which wraps it with its switch test.
#pragma once

#include <vector>

#include "solver.hpp"

namespace core::sim {

class RK45 : public AdaptiveStepper {
public:
    explicit RK45(int n);
    bool attempt(Problem& p, double t, double h, const double* z, const double* f0, double* znew, double* fnew,
                 double* errv, const double* mag, const Options& opt, Stats& st, std::vector<Switch>& sw,
                 bool rejected_last, double& h_next) override;
    void dense(Problem& p, double t0, double h, double x, const double* z0, const double* z1, double* out,
               Stats& st) override;
    int order() const override { return 5; }
    void reset();  // fresh controller memory (auto switching back to this method)
    bool stiff_event() const { return stiff_event_; }
    double hlamb() const { return hlamb_; }

private:
    void stiffness_test(double h, const double* znew, int ne, double tn, Stats& st);
    int n_;
    std::vector<double> K_, y6_;  // (7, n) stages, K[0] = f(t, z), K[6] = f at the new point (FSAL); the 6th state
    double errold_ = 1e-4, hlamb_ = 0.0;
    int iasti_ = 0, nonsti_ = 0;
    bool stiff_event_ = false;
};

}  // namespace core::sim
