// auto: rk45 while the problem is not stiff, radau while it is, the way LSODA alternates between Adams and BDF.  It
// starts with rk45; when DOPRI5's stiffness test fires (h |lambda| > 3.25 on 15 accepted steps), or when an accepted
// state touches something after touching nothing (compliant contact is stiff: its regularised friction has
// |lambda| ~ mu f_n / (v_s m), 1e6 1/s on a standing quadruped, where DOPRI5's estimate, made in the norm of the
// whole state, stays under its threshold), it switches to radau; on radau it estimates the spectral radius rho of
// each Jacobian and switches back when h rho < 2 (the explicit method would be stable at the same step) on 20
// accepted steps in a row.  Every switch is logged (time, method switched to, reason, the measured value).  A switch
// ends the phase with status SWITCHED after the accepted step, and run.cpp resumes with the other phase.
#include "methods.hpp"
#include "radau.hpp"
#include "rk45.hpp"

namespace core::sim {

namespace {

constexpr double NONSTIFF_HRHO = 2.0;
constexpr int NONSTIFF_STEPS = 20;

// Logs a switch (false past MAX_SWITCHES: then no switch happens).
bool log_switch(std::vector<Switch>& sw, Stats& st, double t, int64_t to, int64_t reason, double value) {
    if (st.switches >= MAX_SWITCHES) return false;
    sw.push_back({t, to, reason, value});
    st.switches += 1;
    return true;
}

class AutoRK45 : public AdaptiveStepper {
public:
    explicit AutoRK45(int n) : m_(n) {}
    bool attempt(Problem& p, double t, double h, const double* z, const double* f0, double* znew, double* fnew,
                 double* errv, const double* mag, const Options& opt, Stats& st, std::vector<Switch>& sw,
                 bool rejected_last, double& h_next) override {
        const bool accepted = m_.attempt(p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last, h_next);
        if (accepted) {
            if (m_.stiff_event()) {
                if (log_switch(sw, st, t + h, TO_RADAU, SWITCH_STIFF, m_.hlamb())) st.switch_request = 1;
            } else if (p.touchdown() && log_switch(sw, st, t, TO_RADAU, SWITCH_CONTACT, t)) {
                st.switch_request = 1;
            }
        }
        return accepted;
    }
    void dense(Problem& p, double t0, double h, double x, const double* z0, const double* z1, double* out,
               Stats& st) override {
        m_.dense(p, t0, h, x, z0, z1, out, st);
    }
    int order() const override { return m_.order(); }

private:
    RK45 m_;
};

class AutoRadau : public AdaptiveStepper {
public:
    explicit AutoRadau(int n) : m_(n) {}
    bool attempt(Problem& p, double t, double h, const double* z, const double* f0, double* znew, double* fnew,
                 double* errv, const double* mag, const Options& opt, Stats& st, std::vector<Switch>& sw,
                 bool rejected_last, double& h_next) override {
        const bool accepted = m_.attempt(p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last, h_next);
        const double rho = m_.rho();
        if (accepted && rho >= 0) {
            calm_ = h * rho < NONSTIFF_HRHO ? calm_ + 1 : 0;
            if (calm_ >= NONSTIFF_STEPS && !(opt.stay_stiff_in_contact && p.touching()) &&
                log_switch(sw, st, t + h, TO_RK45, SWITCH_NONSTIFF, h * rho)) {
                st.switch_request = 1;
                h_next = h;
            }
        }
        return accepted;
    }
    void dense(Problem& p, double t0, double h, double x, const double* z0, const double* z1, double* out,
               Stats& st) override {
        m_.dense(p, t0, h, x, z0, z1, out, st);
    }
    int order() const override { return m_.order(); }

private:
    Radau m_;
    int calm_ = 0;  // accepted steps in a row with h rho < NONSTIFF_HRHO
};

}  // namespace

std::unique_ptr<AdaptiveStepper> make_auto_rk45(int n) { return std::make_unique<AutoRK45>(n); }
std::unique_ptr<AdaptiveStepper> make_auto_radau(int n) { return std::make_unique<AutoRadau>(n); }

}  // namespace core::sim
