// integrate and difference on the configuration manifold, one state (checked and normalised by the Python entry,
// dynamics/configuration.py; lengths checked again here).
#include "arrays.hpp"
#include "numpy.hpp"
#include "configuration.hpp"

namespace bind {

void expose_configuration(nb::module_& m) {
    m.def("integrate", [](const core::Model& model, In<1> q, In<1> v, double dt, nb::handle out_) {
        const Output out = output_of(out_, 1);
        require(length(q) == model.nq && length(v) == model.nv && length(out) == model.nq, "q, v: lengths");
        std::vector<double> delta(model.nv);
        core::integrate(model, q.data(), v.data(), dt, delta.data(), out.data());
    });
    m.def("retract", [](const core::Model& model, In<1> q0, In<1> delta, nb::handle out_) {
        const Output out = output_of(out_, 1);
        require(length(q0) == model.nq && length(delta) == model.nv && length(out) == model.nq, "q0, delta: lengths");
        core::retract(model, q0.data(), delta.data(), out.data());
    });
    m.def("chart_rate", [](const core::Model& model, In<1> q, In<1> delta, In<1> v, nb::handle out_) {
        const Output out = output_of(out_, 1);
        require(length(q) == model.nq && length(delta) == model.nv && length(v) == model.nv && length(out) == model.nv,
                "q, delta, v: lengths");
        core::chart_rate(model, q.data(), delta.data(), v.data(), out.data());
    });
    m.def("difference", [](const core::Model& model, In<1> q0, In<1> q1, nb::handle out_) {
        const Output out = output_of(out_, 1);
        require(length(q0) == model.nq && length(q1) == model.nq && length(out) == model.nv, "q0, q1: lengths");
        core::difference(model, q0.data(), q1.data(), out.data());
    });
}

}  // namespace bind
