// Narrow phase: the contacts of every candidate pair of a scene at the bodies' world poses (the C++ side of
// dynamics/contact/narrow_phase.py, whose docstring has the table of pair functions).  Allocation-free: the caller
// owns the buffer.
#pragma once

#include <cstdint>
#include <vector>

#include "contact/scene.hpp"
#include "spatial.hpp"

namespace core::contact {

// Contacts of one evaluation, room for K (the scene's max_contacts); collide fills the first n.
struct ContactBuffer {
    std::vector<int64_t> pair;  // (K,) index of the pair
    std::vector<Vec3> point;    // (K,) world point midway between the two surfaces
    std::vector<Vec3> normal;   // (K,) world unit normal, from geometry b towards geometry a
    std::vector<double> depth;  // (K,) penetration > 0
    explicit ContactBuffer(int64_t K = 0) : pair(K), point(K), normal(K), depth(K) {}
    int64_t capacity() const { return static_cast<int64_t>(depth.size()); }
};

// The penetrating contacts of every pair of S whose bounding volumes overlap, at the world poses oMi (one per
// body), written into out (never past its capacity); returns their number.
int64_t collide(const Scene& S, const Transform* oMi, ContactBuffer& out);

// How far apart pair (a, b)'s bounding volumes are (negative when they overlap): the clearance's measure.
double separation(const Scene& S, int64_t a, int64_t b, const Transform* oMi);

// World pose of geometry g.
Transform geometry_pose(const Scene& S, int64_t g, const Transform* oMi);

}  // namespace core::contact
