// NumPy's C API for the single calls (numpy.hpp).  The only file that includes NumPy's headers.
#define NPY_NO_DEPRECATED_API NPY_1_21_API_VERSION
#include <Python.h>
#include <numpy/arrayobject.h>

#include "numpy.hpp"

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
