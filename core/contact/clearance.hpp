// The clearance: how far a robot is from touching anything, and a sound bound on how far it has moved since, so that
// a robot far from everything runs no contact code in its right-hand side (the C++ side of
// dynamics/contact/clearance.py, whose docstring derives the bound).
//
// At an accepted state (the reference): g, the smallest separation of the candidate pairs' bounding volumes, and each
// body k's lever L_k, the largest distance from its origin to a body origin or geometry centre of its subtree.  Along
// a step's chart coordinate delta every such point moves at most D(1) <= D0 + a / (1 - b),
//     a = sum_i |delta_i| (|S_w,i| (L_k(i) + 2 D0) + |S_v,i|),   b = 2 sum_i |delta_i| |S_w,i|   (b < 1),
// and while 2 D < g no bounding volumes overlap: the narrow phase would find nothing.
#pragma once

#include <vector>

#include "contact/narrow_phase.hpp"
#include "model.hpp"

namespace core::contact {

class Clearance {
public:
    explicit Clearance(const Model& model);
    // The bound D at the chart coordinate delta of the present step (inf when the bound does not hold).
    double moved(const double* delta) const;
    // True when no pair's bounding volumes can overlap at delta.
    bool apart(const double* delta) const;
    // After an accepted step ending at delta: D0 = the bound there; true while it leaves room (D0 < g / 4), false
    // when the accepted state must be measured again (set_reference).
    bool advance(const double* delta);
    // The state whose world poses are oMi becomes the reference: g, the levers, D0 = 0.
    void set_reference(const Scene& S, const Transform* oMi);
    // No reference: the next accepted state is measured (a projection moved the base).
    void forget() { referenced_ = false; }
    double separation() const { return g_; }  // g at the reference
    double bound() const { return d0_; }      // D0: the motion since the reference, as last advanced
    bool referenced() const { return referenced_; }

private:
    void reach(int j, const Vec3& x, const Transform* oMi);

    const Model& model_;
    double g_ = 0.0, d0_ = 0.0;
    bool referenced_ = false;
    std::vector<double> lever_, sw_, sv_;  // nb; nv, nv
    std::vector<int> dof_body_;            // nv
};

}  // namespace core::contact
