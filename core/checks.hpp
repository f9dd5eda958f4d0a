// What a single call checks of its inputs before it runs (the Python entry checks a batch; dynamics/checks.py).
// A single call that finds a bad input does not compute: it tells its caller, whose general path names the
// input and what was expected.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "joints.hpp"

namespace core {

inline bool all_finite(const double* x, long n) {
    for (long k = 0; k < n; ++k)
        if (!std::isfinite(x[k])) return false;
    return true;
}

// Whether x[0..n) holds a nan or an inf, without a branch per number: a double is not finite when its 11 exponent
// bits are all ones, and then adding one to the exponent field carries into the sign bit.  Integer and-add-or,
// which the compiler vectorises (a floating-point test would not be, without -ffast-math).
inline bool any_nonfinite(const double* x, long n) {
    constexpr uint64_t EXP = 0x7ff0000000000000ull, ONE = 1ull << 52;
    uint64_t bad = 0;
    for (long k = 0; k < n; ++k) {
        uint64_t bits;
        std::memcpy(&bits, x + k, sizeof bits);
        bad |= (bits & EXP) + ONE;
    }
    return (bad >> 63) != 0;
}

// The first row of the (B, n) row-major X holding a nan or an inf, or -1: rows are scanned 64 at a time by
// any_nonfinite, and only a block that has one is looked at row by row.
inline long first_nonfinite_row(const double* X, long B, long n) {
    constexpr long ROWS = 64;
    for (long b0 = 0; b0 < B; b0 += ROWS) {
        const long rows = std::min(ROWS, B - b0);
        if (!any_nonfinite(X + b0 * n, rows * n)) continue;
        for (long b = b0; b < b0 + rows; ++b)
            if (!all_finite(X + b * n, n)) return b;
    }
    return -1;
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
