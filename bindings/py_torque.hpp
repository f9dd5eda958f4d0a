// A Python callable f(t, q, v) -> (nv,) as a torque source (core/control/sources.hpp's TorqueCallback), for a
// simulate run (bindings/simulation.cpp) and a stepped simulator (bindings/simulator.cpp): called with the GIL
// taken, its result passed through `check` (the library's shape check); an exception, or a checked result that is
// not a (nv,) float64 array, is kept and the run stops (the callback answers false from then on).  The caller raises
// it after the run with raise_if_failed(), which also forgets it (a simulator's next step calls again).
#pragma once

#include <memory>

#include "control/sources.hpp"
#include "numpy.hpp"

namespace bind {

class PyTorque : public core::control::TorqueCallback {
public:
    PyTorque(nb::object fn, nb::object check, int nq, int nv)
        : fn_(std::move(fn)), check_(std::move(check)), nq_(nq), nv_(nv) {}
    bool torques(double t, const double* q, const double* v, double* tau) override {
        if (error_) return false;
        nb::gil_scoped_acquire gil;
        try {
            double *pq, *pv;
            nb::object Q = new_array(nq_, &pq), V = new_array(nv_, &pv);
            std::copy(q, q + nq_, pq);
            std::copy(v, v + nv_, pv);
            nb::object out = fn_(t, Q, V);
            if (!check_.is_none()) out = check_(out);
            if (const double* r = vector_of(out, nv_)) {
                std::copy(r, r + nv_, tau);
                return true;
            }
            PyErr_SetString(PyExc_ValueError, "torque: the callable's checked result is not a (nv,) float64 array");
            error_ = std::make_unique<nb::python_error>();
        } catch (nb::python_error& e) {
            error_ = std::make_unique<nb::python_error>(std::move(e));
        }
        return false;
    }
    bool failed() const override { return error_ != nullptr; }
    void raise_if_failed() {
        if (error_) {
            auto e = std::move(error_);
            e->restore();
            throw nb::python_error();
        }
    }

private:
    nb::object fn_, check_;
    int nq_, nv_;
    std::unique_ptr<nb::python_error> error_;
};

}  // namespace bind
