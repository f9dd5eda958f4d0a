// A run's contact (contact_model.hpp): the evaluation of one state and the simulation's hooks, each the
// counterpart of a function of dynamics/contact/resolve.py.
#include "contact/contact_model.hpp"

#include <algorithm>
#include <cmath>

namespace core::contact {

ContactModel::ContactModel(const Model& model, const ContactArrays& arrays, bool exact)
    : model_(model), a_(arrays), exact_(exact), buf_(arrays.K), detail_(arrays.K * NDETAIL), data_(model),
      oMi_(model.nb), fb_(model.nb), clear_(model), fdw_(model.nv), scratch_(model.nv),
      last_q_(model.nq, std::nan("")) {}

int64_t ContactModel::found(const double* q) {
    for (int i = 0; i < model_.nb; ++i) forward_body(model_, data_, i, q, nullptr, false);
    world_poses(model_, data_.X.data(), oMi_.data());
    const int64_t n = collide(a_.scene, oMi_.data(), buf_);
    stamp(q, n);
    return n;
}

double ContactModel::evaluate(const double* q, const double* v, double* tau, double* f_ext, int64_t& n) {
    n = found(q);
    if (f_ext) std::fill(f_ext, f_ext + 6 * model_.nb, 0.0);
    if (n == 0) return 0.0;  // touching nothing: no velocities, no forces
    found_since_ = true;
    return contact_wrenches(model_, data_, q, v, n, buf_, a_.pair_body, a_.mat, oMi_.data(), fb_.data(),
                            detail_.data(), f_ext, tau);
}

double ContactModel::torques(const Model&, const double* q, const double* v, double* tau, const double* delta) {
    if (delta && clear_.apart(delta)) return 0.0;
    int64_t n;
    return evaluate(q, v, tau, nullptr, n);
}

// After the ABA's first pass at (q, v): pA_i -= every body's contact wrench (the ABA's other passes take them as
// external forces), from that pass's poses and velocities; nothing at all while the robot is clear of everything.
double ContactModel::bias(const Model&, Data& data, const double* q, const double*, const double* delta) {
    if (clear_.apart(delta)) return 0.0;
    world_poses(model_, data.X.data(), oMi_.data());
    const int64_t n = collide(a_.scene, oMi_.data(), buf_);
    stamp(q, n);
    if (n == 0) return 0.0;
    found_since_ = true;
    std::fill(fb_.begin(), fb_.end(), Force{});
    const double power = apply_contacts(n, buf_, a_.pair_body, a_.mat, oMi_.data(), data.v.data(), fb_.data(),
                                        detail_.data());
    for (int i = 0; i < model_.nb; ++i) {
        data.pA[i].n = data.pA[i].n - fb_[i].n;
        data.pA[i].f = data.pA[i].f - fb_[i].f;
    }
    return power;
}

// After an accepted step: the largest penetration, the time in contact, and the clearance from the accepted state
// when it must be measured again.
void ContactModel::track(double t, const double* base, const double*, const double* delta) {
    double* tr = a_.track;
    if (clear_.advance(delta)) {  // still clear of everything since the reference: no contact
        touching_ = false;
        tr[2] = t;
        return;
    }
    if (lean_ && ++unmeasured_ < LEAN_MEASURE) {  // the right-hand sides look for contacts themselves
        clear_.forget();
        tr[2] = t;
        return;
    }
    unmeasured_ = 0;
    const int64_t n = found(base);
    clear_.set_reference(a_.scene, oMi_.data());
    for (int64_t k = 0; k < n; ++k) tr[0] = std::max(tr[0], buf_.depth[k]);
    if (n > 0) {
        tr[1] += t - tr[2];
        found_since_ = true;
    }
    touching_ = n > 0;
    tr[2] = t;
}

bool ContactModel::touched() {
    const bool found = found_since_;
    found_since_ = false;
    return found;
}

bool ContactModel::touchdown() {
    if (!touching_) {  // the accepted state touches nothing: the next contact is a new episode
        reported_ = false;
        return false;
    }
    if (reported_) return false;
    reported_ = true;
    return true;
}

bool ContactModel::jacobian(const Model&, const double* q, const double* v, double* dq, double* dv) {
    const int64_t n = std::equal(q, q + model_.nq, last_q_.begin()) ? last_n_ : found(q);
    contact_force_derivatives(model_, n, buf_, a_.pair_body, a_.mat, oMi_.data(), v, dq, dv, fdw_);
    return exact_;
}

// Sample j's active contacts into out[j] (a run that keeps them).
void ContactModel::emit(int64_t j, const double* q, const double* v) {
    if (!a_.out || j >= a_.T) return;
    int64_t n;
    std::fill(scratch_.begin(), scratch_.end(), 0.0);
    evaluate(q, v, scratch_.data(), nullptr, n);
    a_.out_n[j] = n;
    double* o = a_.out + j * a_.K * NOUT;
    for (int64_t k = 0; k < n; ++k, o += NOUT) {
        const double* d = detail_.data() + NDETAIL * k;
        o[0] = static_cast<double>(buf_.pair[k]);
        for (int r = 0; r < 3; ++r) {
            o[1 + r] = buf_.point[k][r];
            o[4 + r] = buf_.normal[k][r];
            o[8 + r] = d[D_FT + r];
            o[12 + r] = d[D_SLIP + r];
        }
        o[7] = d[D_FN];
        o[11] = buf_.depth[k];
    }
}

}  // namespace core::contact
