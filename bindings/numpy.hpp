// The single calls' arrays, through NumPy's C API (numpy.cpp): a state crosses into the core as a pointer after a
// few flag tests (~10 ns), and the result is a new NumPy array made here.  nanobind's ndarray takes ~250 ns per
// argument (it asks each array for a DLPack capsule), which is most of a microsecond call; the batches use it.
#pragma once

#include <nanobind/nanobind.h>

#include <cstdint>

namespace bind {

namespace nb = nanobind;

// Makes NumPy's C API usable; called once when the module is imported.
void import_numpy();

// The data of x if it is exactly a NumPy ndarray (not a subclass) of native float64, C-contiguous, aligned, of
// shape (n,); else null (the caller's general path checks and converts).
const double* vector_of(nb::handle x, long n);

// An output array a call writes into: exactly a writable NumPy ndarray (not a subclass) of native float64,
// C-contiguous and aligned, of rank `ndim` (output_of); anything else is a TypeError, never a converted copy
// (which would be written and lost).
struct Output {
    double* ptr = nullptr;
    long dims[4] = {0, 0, 0, 0};
    double* data() const { return ptr; }
    long shape(int k) const { return dims[k]; }
};
Output output_of(nb::handle x, int ndim);
inline long length(const Output& x) { return x.dims[0]; }

// An input array the bindings check themselves (the narrow phase's scene, which nanobind would silently convert):
// exactly what `type` says ('d' native float64, 'q' native int64), C-contiguous, aligned, of rank `ndim`; anything
// else is a ValueError naming `name` and what was expected.  The caller checks the shape against its other
// arguments.
struct Input {
    const void* ptr = nullptr;
    long dims[4] = {0, 0, 0, 0};
    long shape(int k) const { return dims[k]; }
    const double* doubles() const { return static_cast<const double*>(ptr); }
    const int64_t* ints() const { return static_cast<const int64_t*>(ptr); }
};
Input input_of(nb::handle x, char type, int ndim, const char* name);

// A new uninitialised int64 array of shape (n,), and its data.
nb::object new_int_array(long n, int64_t** data);

// A new uninitialised float64 array of shape (n,), (r, c) or (a, r, c), and its data.
nb::object new_array(long n, double** data);
nb::object new_array(long r, long c, double** data);
nb::object new_array(long a, long r, long c, double** data);

}  // namespace bind
