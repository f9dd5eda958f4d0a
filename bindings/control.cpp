// The torque sources' derivatives and the closed loop's (core/control/derivatives.hpp) for one state, and the
// rotation log the operational-space references are built with.  Every array is checked here (dtype, layout,
// shape, finite values) and the source and passive torques against the model before the core reads them; a
// Python callable source is called back with the GIL taken (its exception raised after the call).
#include "arrays.hpp"
#include "checks.hpp"
#include "control/derivatives.hpp"
#include "numpy.hpp"

namespace bind {

using core::Model;
namespace control = core::control;

control::Source& source_of(nb::handle x, const Model& model);  // bindings/simulation.cpp
void raise_source_error(nb::handle x);
void require_passive(const control::Passive& p, const Model& model);

namespace {

// The state (t, q, v) and the two (nv, nv) outputs of a derivative call, checked.
struct StateCall {
    const double *q, *v;
    double *out1, *out2;
};

StateCall checked(const Model& model, const control::Passive& ps, double t, nb::handle q_, nb::handle v_,
                  nb::handle o1_, nb::handle o2_) {
    require_passive(ps, model);
    const Input q = input_of(q_, 'd', 1, "q"), v = input_of(v_, 'd', 1, "v");
    require(q.shape(0) == model.nq, "q: expected (nq,)");
    require(v.shape(0) == model.nv, "v: expected (nv,)");
    require(std::isfinite(t), "t: expected a finite number");
    require(core::configuration_ok(model, q.doubles()), "q: expected a finite configuration (non-zero quaternions)");
    require(core::all_finite(v.doubles(), model.nv), "v: expected finite values");
    const Output o1 = output_of(o1_, 2), o2 = output_of(o2_, 2);
    for (const Output* o : {&o1, &o2})
        require(length(*o) == model.nv && o->shape(1) == model.nv, "outputs: expected (nv, nv)");
    require(o1.data() != o2.data(), "outputs: two distinct arrays");
    return {q.doubles(), v.doubles(), o1.data(), o2.data()};
}

}  // namespace

void expose_control(nb::module_& m) {
    using namespace nb::literals;

    // dtau/dq (tangent space) into dq and dtau/dv into dv (nv x nv) of the source at (t, q, v); returns True if
    // analytical, False if differenced (a Python callable; the operational space on other joints than 1-dof).
    m.def("torque_source_derivatives", [](const Model& model, const control::Passive& passive, nb::handle source,
                                          double t, nb::handle q, nb::handle v, nb::handle dq, nb::handle dv) {
        const control::Source& src = source_of(source, model);
        const StateCall c = checked(model, passive, t, q, v, dq, dv);
        control::SourceWorkspace ws(model);
        bool analytical;
        {
            nb::gil_scoped_release unlocked;
            analytical = control::source_derivatives_tangent(model, src, passive, ws, t, c.q, c.v, c.out1, c.out2);
        }
        raise_source_error(source);
        return analytical;
    }, "model"_a, "passive"_a, "source"_a, "t"_a, "q"_a, "v"_a, "dq"_a, "dv"_a);

    // tau (nv,) = the source's torques at (t, q, v) (the simulation's evaluation; the tests difference it).
    m.def("source_torques", [](const Model& model, const control::Passive& passive, nb::handle source, double t,
                               nb::handle q_, nb::handle v_, nb::handle tau_) {
        control::Source& src = source_of(source, model);
        require_passive(passive, model);
        const Input q = input_of(q_, 'd', 1, "q"), v = input_of(v_, 'd', 1, "v");
        require(q.shape(0) == model.nq && v.shape(0) == model.nv, "q, v: expected (nq,), (nv,)");
        require(std::isfinite(t), "t: expected a finite number");
        require(core::configuration_ok(model, q.doubles()), "q: expected a finite configuration (non-zero quaternions)");
        require(core::all_finite(v.doubles(), model.nv), "v: expected finite values");
        const Output tau = output_of(tau_, 1);
        require(length(tau) == model.nv, "tau: expected (nv,)");
        control::SourceWorkspace ws(model);
        {
            nb::gil_scoped_release unlocked;
            control::source_torques(model, src, passive, ws, t, q.doubles(), v.doubles(), tau.data());
        }
        raise_source_error(source);
    }, "model"_a, "passive"_a, "source"_a, "t"_a, "q"_a, "v"_a, "tau"_a);

    // da/dq (tangent space) into da_dq and da/dv into da_dv (nv x nv) of a = ABA(q, v, tau_source + tau_passive);
    // returns -1, or a body whose joint makes M singular at q.
    m.def("closed_loop_derivatives", [](const Model& model, const control::Passive& passive, nb::handle source,
                                        double t, nb::handle q, nb::handle v, nb::handle da_dq, nb::handle da_dv) {
        const control::Source& src = source_of(source, model);
        const StateCall c = checked(model, passive, t, q, v, da_dq, da_dv);
        control::SourceWorkspace ws(model);
        int singular;
        {
            nb::gil_scoped_release unlocked;
            singular = control::closed_loop_derivatives(model, src, passive, ws, t, c.q, c.v, c.out1, c.out2);
        }
        raise_source_error(source);
        return singular;
    }, "model"_a, "passive"_a, "source"_a, "t"_a, "q"_a, "v"_a, "da_dq"_a, "da_dv"_a);

    // The rotation vector theta * axis (3,) of the rotation matrix R (3, 3), core::rotation_log.
    m.def("rotation_log", [](nb::handle R_) {
        const Input R = input_of(R_, 'd', 2, "R");
        require(R.shape(0) == 3 && R.shape(1) == 3, "R: expected (3, 3)");
        require(core::all_finite(R.doubles(), 9), "R: expected finite values");
        core::Mat3 M;
        for (int i = 0; i < 9; ++i) M[i] = R.doubles()[i];
        const core::Vec3 w = core::rotation_log(M);
        double* out;
        nb::object o = new_array(3, &out);
        out[0] = w.x, out[1] = w.y, out[2] = w.z;
        return o;
    }, "R"_a);
}

}  // namespace bind
