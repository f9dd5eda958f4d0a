// The array types the bindings take, and the checks that guard the core's memory.
//
// Single calls read their states through NumPy's C API (numpy.hpp).  Batches take what the public function
// prepared (checked in Python) as nanobind arrays, an input in another layout or dtype copied by nanobind, and
// write into outputs that must be exactly what they claim (numpy.hpp's output_of); every shape is checked here
// again, a second wall: no array reaches the core with a shape it does not expect.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "model.hpp"
#include "parallel.hpp"

namespace bind {

namespace nb = nanobind;

template <size_t N>
using In = nb::ndarray<const double, nb::ndim<N>, nb::c_contig, nb::device::cpu>;
using Ints = nb::ndarray<const int64_t, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

inline void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument(what);
}

// Rows of a batch argument: B rows, or one row shared by every state; each of n columns.
template <class A>
inline void require_rows(const A& x, long B, long n, const char* name) {
    require((static_cast<long>(x.shape(0)) == B || x.shape(0) == 1) && static_cast<long>(x.shape(1)) == n,
            std::string(name) + ": expected (" + std::to_string(B) + " or 1, " + std::to_string(n) + ") rows");
}
template <class A>
inline const double* row(const A& x, long b) {
    return x.data() + (x.shape(0) == 1 ? 0 : b) * x.shape(1);
}
template <class A>
inline long length(const A& x) {
    return static_cast<long>(x.shape(0));
}

// External forces of a batch: (1 or B, nb or 0, 6); null for a state when there are none.
inline void require_forces(const In<3>& F, long B, int nb) {
    require((static_cast<long>(F.shape(0)) == B || F.shape(0) == 1) && (F.shape(1) == 0 || F.shape(1) == size_t(nb)) &&
                F.shape(2) == 6,
            "f_ext: expected (B or 1, nbodies or 0, 6)");
}
inline const double* forces(const In<3>& F, long b) {
    if (F.shape(1) == 0) return nullptr;
    return F.data() + (F.shape(0) == 1 ? 0 : b) * F.shape(1) * 6;
}

inline core::Vec3 vec3(const In<1>& x, const char* name) {
    require(x.shape(0) == 3, std::string(name) + ": expected 3 numbers");
    return {x(0), x(1), x(2)};
}

// A batch's outcome as Python reads it: (done, expired, failed state or -1, its code).
inline nb::tuple status(const core::BatchStatus& s) { return nb::make_tuple(s.done, s.expired, s.failed, s.code); }

}  // namespace bind
