// What a single call checks of its inputs before it runs (the Python entry checks a batch; dynamics/checks.py).
// A single call that finds a bad input does not compute: it tells its caller, whose general path names the
// input and what was expected.
#pragma once

#include <cmath>

#include "joints.hpp"

namespace core {

inline bool all_finite(const double* x, long n) {
    for (long k = 0; k < n; ++k)
        if (!std::isfinite(x[k])) return false;
    return true;
}

// q is a configuration: finite, and every quaternion and planar (cos, sin) non-zero.
inline bool configuration_ok(const Model& model, const double* q) {
    if (!all_finite(q, model.nq)) return false;
    if (model.has_unit_blocks)
        for (int i = 0; i < model.nb; ++i)
            if (!joint_config_ok(model, i, q)) return false;
    return true;
}

// Whether any x[k] != 0: a term with x = 0 is skipped, as the batch's general path skips it.
inline bool any_nonzero(const double* x, long n) {
    for (long k = 0; k < n; ++k)
        if (x[k] != 0.0) return true;
    return false;
}

}  // namespace core
