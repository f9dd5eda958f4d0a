// The clearance (clearance.hpp), in the order of operations of dynamics/contact/clearance.py.
#include "contact/clearance.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace core::contact {

namespace {
constexpr double REL = 1e-9, ABS = 1e-12;  // the bound's margins against rounding
constexpr double RENEW = 0.25;             // D0 beyond this fraction of g: the next accepted state is measured
double norm(const Vec3& a) { return std::sqrt(dot(a, a)); }
}  // namespace

Clearance::Clearance(const Model& model)
    : model_(model), lever_(model.nb), sw_(model.nv), sv_(model.nv), dof_body_(model.nv) {
    for (int k = 0; k < model.nv; ++k) sw_[k] = norm(model.S[k].w), sv_[k] = norm(model.S[k].v);
    for (int b = 0; b < model.nb; ++b)
        for (int k = model.v_idx[b]; k < model.v_idx[b] + model.nv_j[b]; ++k) dof_body_[k] = b;
}

double Clearance::moved(const double* delta) const {
    double a = 0.0, b = 0.0;
    for (int i = 0; i < model_.nv; ++i) {
        const double x = std::abs(delta[i]);
        a += x * (sw_[i] * (lever_[dof_body_[i]] + 2.0 * d0_) + sv_[i]);
        b += x * sw_[i];
    }
    b *= 2.0;
    if (!(b < 1.0)) return std::numeric_limits<double>::infinity();  // (also a NaN delta)
    return d0_ + a / (1.0 - b);
}

bool Clearance::apart(const double* delta) const {
    return referenced_ && 2.0 * moved(delta) * (1.0 + REL) + ABS < g_;
}

bool Clearance::advance(const double* delta) {
    d0_ = moved(delta);
    return referenced_ && d0_ * (1.0 + REL) + ABS < RENEW * g_;
}

void Clearance::set_reference(const Scene& S, const Transform* oMi) {
    double g = std::numeric_limits<double>::infinity();
    for (int64_t k = 0; k < S.npairs; ++k) g = std::min(g, contact::separation(S, S.pair_a[k], S.pair_b[k], oMi));
    std::fill(lever_.begin(), lever_.end(), 0.0);
    for (int j = 0; j < model_.nb; ++j) reach(j, oMi[j].p, oMi);  // body origins
    for (int64_t m = 0; m < S.ng; ++m)                            // geometry centres
        if (S.body[m] >= 0) reach(static_cast<int>(S.body[m]), geometry_pose(S, m, oMi).p, oMi);
    g_ = g, d0_ = 0.0, referenced_ = true;
}

// L_k = max(L_k, |x - o_k|) for body j and each of its ancestors k (x: a point of j's subtree).
void Clearance::reach(int j, const Vec3& x, const Transform* oMi) {
    for (int k = j; k >= 0; k = model_.parents[k]) {
        const double d0 = x.x - oMi[k].p.x, d1 = x.y - oMi[k].p.y, d2 = x.z - oMi[k].p.z;
        lever_[k] = std::max(lever_[k], std::sqrt(d0 * d0 + d1 * d1 + d2 * d2));
    }
}

}  // namespace core::contact
