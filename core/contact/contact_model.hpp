// A contact made concrete for one run of one model: the scene, each pair's bodies and material, and the state a
// simulation keeps (the contacts of the last evaluation, the clearance, what the report and the outputs read).  It
// is the simulation's ContactHooks (simulation/robot_problem.hpp) and a single evaluation's workspace (the C++ side
// of dynamics/contact/resolve.py).
#pragma once

#include <cstdint>
#include <vector>

#include "contact/clearance.hpp"
#include "contact/force_derivatives.hpp"
#include "contact/forces.hpp"
#include "contact/narrow_phase.hpp"
#include "data.hpp"
#include "simulation/robot_problem.hpp"

namespace core::contact {

// What the caller owns (numpy's arrays, checked by the bindings) and the model reads or writes through.
struct ContactArrays {
    Scene scene;
    const int64_t* pair_body = nullptr;  // (npairs, 2) the bodies of each pair's geometries a and b (-1: world)
    const double* mat = nullptr;         // (npairs, NMAT)
    int64_t K = 0;                       // the most contacts the pairs produce at once (the buffer's capacity)
    double* track = nullptr;             // (3,) largest penetration (m), time in contact (s), last step's t
    double* out = nullptr;               // (T, K, NOUT) contacts kept per sample, or null
    int64_t* out_n = nullptr;            // (T,) how many per sample
    int64_t T = 0;
};

//: columns of a kept contact: pair, point (3), normal (3), normal force, friction (3), depth, slip velocity (3)
constexpr int NOUT = 15;

class ContactModel : public sim::ContactHooks {
public:
    // exact: the run's Jacobian needs the exact d tau_c/dq (a run with sensitivities differences it).
    ContactModel(const Model& model, const ContactArrays& arrays, bool exact);

    // A single state: tau += J_c^T f_c, f_ext (nb x 6, body frame, [force, torque]; may be null) = the body wrenches;
    // n = the number of contacts (their rows: buffer(), detail()).  Returns the contact power.
    double evaluate(const double* q, const double* v, double* tau, double* f_ext, int64_t& n);
    const ContactBuffer& buffer() const { return buf_; }
    const Model& model() const { return model_; }
    // The clearance (the tests' window): measured at q, the state whose poses it takes as its reference.
    Clearance& clearance() { return clear_; }
    void measure(const double* q) { found(q), clear_.set_reference(a_.scene, oMi_.data()); }
    const double* detail() const { return detail_.data(); }

    // The simulation's hooks (robot_problem.hpp).
    double bias(const Model& model, Data& data, const double* q, const double* v, const double* delta) override;
    double torques(const Model& model, const double* q, const double* v, double* tau, const double* delta) override;
    void emit(int64_t j, const double* q, const double* v) override;
    void track(double t, const double* base, const double* v, const double* delta) override;
    void rebased() override { clear_.forget(); }
    void restart() override {
        clear_.forget();
        found_since_ = touching_ = reported_ = false, unmeasured_ = 0;
    }
    bool touchdown() override;
    bool touching() const override { return touching_; }
    bool touched() override;
    bool jacobian(const Model& model, const double* q, const double* v, double* dq, double* dv) override;
    // Lean tracking, for a simulator's periods that need neither touchdown() nor the report's largest penetration
    // and time in contact: an accepted state that may touch something is measured (a forward pass and the narrow
    // phase, a third of a Go1 Euler step) only every LEAN_MEASURE steps, to find the clearance again once apart.
    void set_lean(bool lean) { lean_ = lean; }
    static constexpr int LEAN_MEASURE = 8;

private:
    int64_t found(const double* q);  // the poses (data_.X, oMi_) and the narrow phase; the number of contacts
    // buf_ and oMi_ now hold the n contacts of q (the narrow phase's last state, which jacobian() takes again
    // rather than repeat it when asked at the same q: the implicit Euler's, after the step's first evaluation)
    void stamp(const double* q, int64_t n) {
        std::copy(q, q + model_.nq, last_q_.begin());
        last_n_ = n;
    }

    const Model& model_;
    ContactArrays a_;
    bool exact_;
    ContactBuffer buf_;
    std::vector<double> detail_;  // (K, NDETAIL)
    Data data_;                   // the forward pass of an evaluation of its own
    std::vector<Transform> oMi_;  // nb world poses
    std::vector<Force> fb_;       // nb body wrenches
    Clearance clear_;
    ForceDerivativesWork fdw_;
    std::vector<double> scratch_;  // nv: a generalised force nobody reads (tracking, outputs)
    // [0] an evaluation found a contact since touched() last looked (the Jacobian's); [1] the last accepted state
    // touches; [2] touchdown() reported the present episode of contact (auto's)
    bool found_since_ = false, touching_ = false, reported_ = false;
    bool lean_ = false;
    int unmeasured_ = 0;  // accepted states not measured since the last that was (lean tracking)
    std::vector<double> last_q_;  // nq: the configuration of buf_ and oMi_ (NaN: none yet)
    int64_t last_n_ = 0;
};

}  // namespace core::contact
