// A scene's geometry and candidate pairs as the core reads them: views into arrays its caller owns (numpy's, from
// dynamics/contact/scene.py's Scene), checked by the bindings before any kernel runs (bindings/contact.cpp).
//
// For geometry g (ng of them): the body it is fixed to (-1: the world), its kind, its size (sphere (r, 0, 0); box
// full edges; capsule and cylinder (r, length, 0); point and plane 0), its pose (R row-major, p) in the body's frame
// (the world pose for body -1; a plane's third column of R is its normal, p = offset n), and its bounding-sphere
// radius about p (inf for a plane).  Pairs (a, b) are ordered so that kind[a] <= kind[b].
#pragma once

#include <cstdint>

namespace core::contact {

enum Kind : int64_t { SPHERE = 0, POINT = 1, CAPSULE = 2, CYLINDER = 3, BOX = 4, PLANE = 5 };

struct Scene {
    int64_t ng = 0, npairs = 0;
    const int64_t* body = nullptr;    // (ng,)
    const int64_t* kind = nullptr;    // (ng,)
    const double* size = nullptr;     // (ng, 3)
    const double* R = nullptr;        // (ng, 3, 3)
    const double* p = nullptr;        // (ng, 3)
    const double* radius = nullptr;   // (ng,)
    const int64_t* pair_a = nullptr;  // (npairs,)
    const int64_t* pair_b = nullptr;  // (npairs,)
};

}  // namespace core::contact
