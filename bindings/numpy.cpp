// NumPy's C API for the single calls (numpy.hpp).  The only file that includes NumPy's headers.
#define NPY_NO_DEPRECATED_API NPY_1_21_API_VERSION
#include <Python.h>
#include <numpy/arrayobject.h>

#include "numpy.hpp"

#include <stdexcept>
#include <string>

namespace bind {

void import_numpy() {
    if (_import_array() < 0) throw nb::python_error();
}

const double* vector_of(nb::handle x, long n) {
    PyObject* o = x.ptr();
    if (!PyArray_CheckExact(o)) return nullptr;
    auto* a = reinterpret_cast<PyArrayObject*>(o);
    if (PyArray_NDIM(a) != 1 || PyArray_DIM(a, 0) != n || PyArray_TYPE(a) != NPY_DOUBLE ||
        !PyArray_ISCARRAY_RO(a) || !PyArray_ISNOTSWAPPED(a))
        return nullptr;
    return static_cast<const double*>(PyArray_DATA(a));
}

Output output_of(nb::handle x, int ndim) {
    PyObject* o = x.ptr();
    auto* a = reinterpret_cast<PyArrayObject*>(o);
    if (!PyArray_CheckExact(o) || PyArray_NDIM(a) != ndim || ndim > 4 || PyArray_TYPE(a) != NPY_DOUBLE ||
        !PyArray_ISCARRAY(a) || !PyArray_ISNOTSWAPPED(a))
        throw nb::type_error("out: expected a writable C-contiguous float64 numpy array of the result's rank");
    Output out;
    out.ptr = static_cast<double*>(PyArray_DATA(a));
    for (int k = 0; k < ndim; ++k) out.dims[k] = PyArray_DIM(a, k);
    return out;
}

Input input_of(nb::handle x, char type, int ndim, const char* name) {
    PyObject* o = x.ptr();
    auto* a = reinterpret_cast<PyArrayObject*>(o);
    const char* dtype = type == 'd' ? "float64" : "int64";
    const int typenum = type == 'd' ? NPY_DOUBLE : NPY_INT64;
    auto fail = [&](const char* what) {
        throw std::invalid_argument(std::string(name) + ": expected a C-contiguous " + dtype + " numpy array of " +
                                    std::to_string(ndim) + " dimension(s)" + what);
    };
    if (!PyArray_Check(o)) fail(", got another type");
    if (!PyArray_EquivTypenums(PyArray_TYPE(a), typenum) || !PyArray_ISNOTSWAPPED(a)) fail(", got another dtype");
    if (PyArray_NDIM(a) != ndim || ndim > 4) fail(", got another number of dimensions");
    if (!PyArray_ISCARRAY_RO(a)) fail(", got a non-contiguous or unaligned one");
    Input in;
    in.ptr = PyArray_DATA(a);
    for (int k = 0; k < ndim; ++k) in.dims[k] = PyArray_DIM(a, k);
    return in;
}

nb::object new_int_array(long n, int64_t** data) {
    npy_intp dims[1] = {n};
    PyObject* o = PyArray_SimpleNew(1, dims, NPY_INT64);
    if (!o) throw nb::python_error();
    *data = static_cast<int64_t*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(o)));
    return nb::steal(o);
}

static nb::object make(int nd, npy_intp* dims, double** data) {
    PyObject* o = PyArray_SimpleNew(nd, dims, NPY_DOUBLE);
    if (!o) throw nb::python_error();
    *data = static_cast<double*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(o)));
    return nb::steal(o);
}

nb::object new_array(long n, double** data) {
    npy_intp dims[1] = {n};
    return make(1, dims, data);
}

nb::object new_array(long r, long c, double** data) {
    npy_intp dims[2] = {r, c};
    return make(2, dims, data);
}

nb::object new_array(long a, long r, long c, double** data) {
    npy_intp dims[3] = {a, r, c};
    return make(3, dims, data);
}

}  // namespace bind
