// RNEA, g(q), CRBA and ABA: one state (exact float64 arrays, lengths and values checked here; false sends the
// caller to its general path) and batches (shapes checked again; the GIL released around the threads).
#include <algorithm>

#include "aba.hpp"
#include "arrays.hpp"
#include "checks.hpp"
#include "coriolis.hpp"
#include "energy.hpp"
#include "minverse.hpp"
#include "crba.hpp"
#include "numpy.hpp"
#include "rnea.hpp"

namespace bind {

using core::all_finite;
using core::any_nonzero;
using core::configuration_ok;

template <class A>
static void require_out(const A& out, long B, std::initializer_list<long> shape, const char* name) {
    require((out.shape(0)) == B, std::string(name) + ": the output has the wrong batch size");
    int d = 1;
    for (long n : shape) require((out.shape(d++)) == n, std::string(name) + ": the output has the wrong shape");
}

void expose_dynamics(nb::module_& m) {
    using namespace nb::literals;
    using core::Data;
    using core::Model;

    // one state: the result, or None when an input is not an exact float64 state of the right length with
    // finite values (the caller's general path then says what is wrong, or converts)
    m.def("rnea", [](const Model& model, nb::handle q, nb::handle v, nb::handle a) -> nb::object {
        const double *pq = vector_of(q, model.nq), *pv = vector_of(v, model.nv), *pa = vector_of(a, model.nv);
        if (!pq || !pv || !pa || !configuration_ok(model, pq) || !all_finite(pv, model.nv) || !all_finite(pa, model.nv))
            return nb::none();
        double* tau;
        nb::object out = new_array(model.nv, &tau);
        core::rnea(model, core::thread_data(model), pq, pv, pa, model.gravity, nullptr, any_nonzero(pv, model.nv),
                   any_nonzero(pa, model.nv), tau);
        return out;
    }, "model"_a, "q"_a.none(), "v"_a.none(), "a"_a.none());

    m.def("bias_forces", [](const Model& model, nb::handle q, nb::handle v) -> nb::object {
        const double *pq = vector_of(q, model.nq), *pv = vector_of(v, model.nv);
        if (!pq || !pv || !configuration_ok(model, pq) || !all_finite(pv, model.nv)) return nb::none();
        double* tau;
        nb::object out = new_array(model.nv, &tau);
        core::rnea(model, core::thread_data(model), pq, pv, pv, model.gravity, nullptr, any_nonzero(pv, model.nv),
                   false, tau);
        return out;
    }, "model"_a, "q"_a.none(), "v"_a.none());

    m.def("gravity_torques", [](const Model& model, nb::handle q) -> nb::object {
        const double* pq = vector_of(q, model.nq);
        if (!pq || !configuration_ok(model, pq)) return nb::none();
        double* tau;
        nb::object out = new_array(model.nv, &tau);
        core::gravity_torques(model, core::thread_data(model), pq, model.gravity, tau);
        return out;
    }, "model"_a, "q"_a.none());

    m.def("crba", [](const Model& model, nb::handle q) -> nb::object {
        const double* pq = vector_of(q, model.nq);
        if (!pq || !configuration_ok(model, pq)) return nb::none();
        double* M;
        nb::object out = new_array(model.nv, model.nv, &M);
        std::fill(M, M + model.nv * model.nv, 0.0);
        core::crba(model, core::thread_data(model), pq, M);
        return out;
    }, "model"_a, "q"_a.none());

    // None also for a singular joint: the general path names it
    m.def("aba", [](const Model& model, nb::handle q, nb::handle v, nb::handle tau) -> nb::object {
        const double *pq = vector_of(q, model.nq), *pv = vector_of(v, model.nv), *pt = vector_of(tau, model.nv);
        if (!pq || !pv || !pt || !configuration_ok(model, pq) || !all_finite(pv, model.nv) || !all_finite(pt, model.nv))
            return nb::none();
        double* qdd;
        nb::object out = new_array(model.nv, &qdd);
        if (core::aba(model, core::thread_data(model), pq, pv, pt, model.gravity, nullptr, any_nonzero(pv, model.nv),
                      qdd) >= 0)
            return nb::none();
        return out;
    }, "model"_a, "q"_a.none(), "v"_a.none(), "tau"_a.none());

    m.def("inverse_mass_matrix", [](const Model& model, nb::handle q) -> nb::object {
        const double* pq = vector_of(q, model.nq);
        if (!pq || !configuration_ok(model, pq)) return nb::none();
        double* Minv;
        nb::object out = new_array(model.nv, model.nv, &Minv);
        if (core::inverse_mass_matrix(model, core::thread_data(model), pq, Minv) >= 0) return nb::none();
        return out;
    }, "model"_a, "q"_a.none());

    m.def("rnea_batch", [](const Model& model, In<2> Q, In<2> V, In<2> A, In<3> F, In<1> gravity, bool with_v,
                           bool with_a, nb::handle out_, int nthreads, double seconds) {
        const Output out = output_of(out_, 2);
        const long B = length(out), nv = model.nv;
        require_rows(Q, B, model.nq, "q"), require_rows(V, B, nv, "v"), require_rows(A, B, nv, "a");
        require_forces(F, B, model.nb), require_out(out, B, {nv}, "tau");
        const core::Vec3 g = vec3(gravity, "gravity");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, Data& d) {
                core::rnea(model, d, row(Q, b), row(V, b), row(A, b), g, forces(F, b), with_v, with_a,
                           out.data() + b * nv);
                return -1;
            });
        }
        return status(s);
    });

    m.def("gravity_batch", [](const Model& model, In<2> Q, In<1> gravity, nb::handle out_, int nthreads, double seconds) {
        const Output out = output_of(out_, 2);
        const long B = length(out), nv = model.nv;
        require_rows(Q, B, model.nq, "q"), require_out(out, B, {nv}, "tau");
        const core::Vec3 g = vec3(gravity, "gravity");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, Data& d) {
                core::gravity_torques(model, d, row(Q, b), g, out.data() + b * nv);
                return -1;
            });
        }
        return status(s);
    });

    // zeroed: out is all zeros already (numpy's zeros: fresh pages the kernel zeroes on first touch, in the threads
    // that write them), so the entries between branches, which the CRBA does not write, are not filled again
    m.def("crba_batch", [](const Model& model, In<2> Q, nb::handle out_, int nthreads, double seconds, bool zeroed) {
        const Output out = output_of(out_, 3);
        const long B = length(out), nv = model.nv;
        require_rows(Q, B, model.nq, "q"), require_out(out, B, {nv, nv}, "M");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, Data& d) {
                double* M = out.data() + b * nv * nv;
                if (!zeroed) std::fill(M, M + nv * nv, 0.0);
                core::crba(model, d, row(Q, b), M);
                return -1;
            });
        }
        return status(s);
    }, nb::arg("model"), nb::arg("q"), nb::arg("out"), nb::arg("nthreads"), nb::arg("seconds"),
       nb::arg("zeroed") = false);

    m.def("aba_batch", [](const Model& model, In<2> Q, In<2> V, In<2> T, In<3> F, In<1> gravity, bool with_v,
                          nb::handle out_, int nthreads, double seconds) {
        const Output out = output_of(out_, 2);
        const long B = length(out), nv = model.nv;
        require_rows(Q, B, model.nq, "q"), require_rows(V, B, nv, "v"), require_rows(T, B, nv, "tau");
        require_forces(F, B, model.nb), require_out(out, B, {nv}, "qdd");
        const core::Vec3 g = vec3(gravity, "gravity");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, Data& d) {
                return core::aba(model, d, row(Q, b), row(V, b), row(T, b), g, forces(F, b), with_v,
                                 out.data() + b * nv);
            });
        }
        return status(s);
    });

    m.def("minverse_batch", [](const Model& model, In<2> Q, nb::handle out_, int nthreads, double seconds) {
        const Output out = output_of(out_, 3);
        const long B = length(out), nv = model.nv;
        require_rows(Q, B, model.nq, "q"), require_out(out, B, {nv, nv}, "Minv");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, Data& d) {
                return core::inverse_mass_matrix(model, d, row(Q, b), out.data() + b * nv * nv);
            });
        }
        return status(s);
    });

    // out (B, 2): (T, U) per state; T only when kinetic (V read), U only when potential
    m.def("energy_batch", [](const Model& model, In<2> Q, In<2> V, In<1> gravity, bool kinetic, bool potential,
                             nb::handle out_, int nthreads, double seconds) {
        const Output out = output_of(out_, 2);
        const long B = length(out);
        require_rows(Q, B, model.nq, "q"), require_out(out, B, {2}, "energies");
        if (kinetic) require_rows(V, B, model.nv, "v");
        const core::Vec3 g = vec3(gravity, "gravity");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, Data& d) {
                core::energies(model, d, row(Q, b), kinetic ? row(V, b) : nullptr, g, kinetic, potential,
                               out.data()[2 * b], out.data()[2 * b + 1]);
                return -1;
            });
        }
        return status(s);
    });

    m.def("coriolis_batch", [](const Model& model, In<2> Q, In<2> V, nb::handle out_, int nthreads, double seconds) {
        const Output out = output_of(out_, 3);
        const long B = length(out), nv = model.nv;
        require_rows(Q, B, model.nq, "q"), require_rows(V, B, nv, "v"), require_out(out, B, {nv, nv}, "C");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, Data& d) {
                core::coriolis_matrix(model, d, row(Q, b), row(V, b), out.data() + b * nv * nv);
                return -1;
            });
        }
        return status(s);
    });
}

}  // namespace bind
