// The analytical derivatives: one state (exact float64 arrays, lengths and values checked here; None sends the
// caller to its general path) and batches into (B, 3, nv, nv) (shapes checked again; the GIL released around the
// threads, one derivatives workspace per thread); the Jacobians of integrate and difference and the kinematics
// derivatives, one state.
#include "aba_derivatives.hpp"
#include "arrays.hpp"
#include "checks.hpp"
#include "configuration_jacobians.hpp"
#include "kinematics_derivatives.hpp"
#include "numpy.hpp"
#include "rnea_derivatives.hpp"

namespace bind {

using core::all_finite;
using core::configuration_ok;

namespace {

// The batch's output: (B, 3, nv, nv), the three matrices of state b at out[b].
void require_matrices(const Output& out, long nv, const char* name) {
    require(out.shape(1) == 3 && out.shape(2) == nv && out.shape(3) == nv,
            std::string(name) + ": expected an output of shape (B, 3, " + std::to_string(nv) + ", " +
                std::to_string(nv) + ")");
}

// Two (nv, nv) outputs of one state.
void require_square(const Output& A, const Output& B, long nv, const char* name) {
    require(A.shape(0) == nv && A.shape(1) == nv && B.shape(0) == nv && B.shape(1) == nv,
            std::string(name) + ": expected outputs of shape (" + std::to_string(nv) + ", " + std::to_string(nv) + ")");
}

// n outputs of shape (rows, nv) of one state.
void require_rows_nv(const Output* outs, int n, long rows, long nv, const char* name) {
    for (int k = 0; k < n; ++k)
        require(outs[k].shape(0) == rows && outs[k].shape(1) == nv, std::string(name) + ": expected outputs of shape (" +
                                                                        std::to_string(rows) + ", " + std::to_string(nv) + ")");
}

// Three new (nv, nv) arrays and their data.
nb::tuple three_matrices(long nv, double** x, double** y, double** z) {
    nb::object a = new_array(nv, nv, x), b = new_array(nv, nv, y), c = new_array(nv, nv, z);
    return nb::make_tuple(a, b, c);
}

}  // namespace

// A batch of RNEA or ABA derivatives: the shapes checked, one derivatives workspace per thread (allocated before
// the threads start), kernel(d, ws, q, v, a or tau, g, f_ext, out) -> -1 or a singular joint's body per state,
// writing the state's three (nv, nv) matrices at out; the GIL released around the threads.
template <class Kernel>
static nb::object derivatives_batch(const core::Model& model, const In<2>& Q, const In<2>& V, const In<2>& X,
                                    const char* x_name, const In<3>& F, const In<1>& gravity, nb::handle out_,
                                    int nthreads, double seconds, const char* name, Kernel kernel) {
    const Output out = output_of(out_, 4);
    const long B = length(out), nv = model.nv;
    require_rows(Q, B, model.nq, "q"), require_rows(V, B, nv, "v"), require_rows(X, B, nv, x_name);
    require_forces(F, B, model.nb), require_matrices(out, nv, name);
    const core::Vec3 g = vec3(gravity, "gravity");
    core::DerivativesPool pool(model, B, nthreads);
    core::BatchStatus s;
    {
        nb::gil_scoped_release unlocked;
        s = core::run_batch(model, B, nthreads, seconds, [&](long b, core::Data& d) {
            return kernel(d, pool.of(d), row(Q, b), row(V, b), row(X, b), g, forces(F, b),
                          out.data() + b * 3 * nv * nv);
        });
    }
    return status(s);
}

void expose_derivatives(nb::module_& m) {
    using namespace nb::literals;
    using core::Data;
    using core::Model;

    // one state: (dtau_dq, dtau_dv, M), or None when an input is not an exact float64 state of the right length
    // with finite values
    m.def("rnea_derivatives", [](const Model& model, nb::handle q, nb::handle v, nb::handle a) -> nb::object {
        const double *pq = vector_of(q, model.nq), *pv = vector_of(v, model.nv), *pa = vector_of(a, model.nv);
        if (!pq || !pv || !pa || !configuration_ok(model, pq) || !all_finite(pv, model.nv) || !all_finite(pa, model.nv))
            return nb::none();
        double *dq, *dv, *M;
        nb::tuple out = three_matrices(model.nv, &dq, &dv, &M);
        core::rnea_derivatives(model, core::thread_derivatives_data(model), pq, pv, pa, model.gravity, nullptr, dq,
                               dv, M);
        return out;
    }, "model"_a, "q"_a.none(), "v"_a.none(), "a"_a.none());

    // one state: (da_dq, da_dv, Minv); None also for a singular joint (the general path names it)
    m.def("aba_derivatives", [](const Model& model, nb::handle q, nb::handle v, nb::handle tau) -> nb::object {
        const double *pq = vector_of(q, model.nq), *pv = vector_of(v, model.nv), *pt = vector_of(tau, model.nv);
        if (!pq || !pv || !pt || !configuration_ok(model, pq) || !all_finite(pv, model.nv) || !all_finite(pt, model.nv))
            return nb::none();
        double *dq, *dv, *Minv;
        nb::tuple out = three_matrices(model.nv, &dq, &dv, &Minv);
        if (core::aba_derivatives(model, core::thread_data(model), core::thread_derivatives_data(model), pq, pv, pt,
                                  model.gravity, nullptr, dq, dv, Minv) >= 0)
            return nb::none();
        return out;
    }, "model"_a, "q"_a.none(), "v"_a.none(), "tau"_a.none());

    m.def("rnea_derivatives_batch", [](const Model& model, In<2> Q, In<2> V, In<2> A, In<3> F, In<1> gravity,
                                       nb::handle out_, int nthreads, double seconds) {
        return derivatives_batch(model, Q, V, A, "a", F, gravity, out_, nthreads, seconds, "rnea_derivatives",
                                 [&](Data&, core::DerivativesData& ws, const double* q, const double* v,
                                     const double* a, const core::Vec3& g, const double* f, double* x) {
                                     const long n = model.nv;
                                     core::rnea_derivatives(model, ws, q, v, a, g, f, x, x + n * n, x + 2 * n * n);
                                     return -1;
                                 });
    });

    m.def("aba_derivatives_batch", [](const Model& model, In<2> Q, In<2> V, In<2> T, In<3> F, In<1> gravity,
                                      nb::handle out_, int nthreads, double seconds) {
        return derivatives_batch(model, Q, V, T, "tau", F, gravity, out_, nthreads, seconds, "aba_derivatives",
                                 [&](Data& d, core::DerivativesData& ws, const double* q, const double* v,
                                     const double* tau, const core::Vec3& g, const double* f, double* x) {
                                     const long n = model.nv;
                                     return core::aba_derivatives(model, d, ws, q, v, tau, g, f, x, x + n * n,
                                                                  x + 2 * n * n);
                                 });
    });

    // the configuration Jacobians of one state (dynamics/configuration_jacobians.py checked it), into two (nv, nv)
    // outputs: (d/dq, d/dv) of integrate(q, v), which depend on v only; (d/dq0, d/dq1) of difference(q0, q1) at
    // its value d (false: a singular block, which no difference gives)
    m.def("integrate_jacobians", [](const Model& model, In<1> v, nb::handle Jq_, nb::handle Jv_) {
        const Output Jq = output_of(Jq_, 2), Jv = output_of(Jv_, 2);
        require(length(v) == model.nv, "v: expected " + std::to_string(model.nv) + " numbers");
        require_square(Jq, Jv, model.nv, "integrate_jacobians");
        core::integrate_jacobians(model, v.data(), Jq.data(), Jv.data());
    });
    m.def("difference_jacobians", [](const Model& model, In<1> d, nb::handle J0_, nb::handle J1_) {
        const Output J0 = output_of(J0_, 2), J1 = output_of(J1_, 2);
        require(length(d) == model.nv, "d: expected " + std::to_string(model.nv) + " numbers");
        require_square(J0, J1, model.nv, "difference_jacobians");
        return core::difference_jacobians(model, d.data(), J0.data(), J1.data());
    });

    // the kinematics derivatives of one state (dynamics/kinematics_derivatives.py checked it): frame f in reference
    // ref (kinematics.hpp), into (6, nv) outputs; the centre of mass's into (3, nv) outputs
    m.def("frame_velocity_derivatives", [](const Model& model, In<1> q, In<1> v, int f, int ref, nb::handle dq_,
                                           nb::handle dv_) {
        const Output outs[2] = {output_of(dq_, 2), output_of(dv_, 2)};
        require(length(q) == model.nq && length(v) == model.nv, "q, v: lengths");
        require(f >= 0 && f < model.nf && ref >= 0 && ref <= 2, "frame or reference out of range");
        require_rows_nv(outs, 2, 6, model.nv, "frame_velocity_derivatives");
        core::frame_velocity_derivatives(model, core::thread_data(model), core::thread_derivatives_data(model),
                                         q.data(), v.data(), f, ref, outs[0].data(), outs[1].data());
    });
    m.def("frame_acceleration_derivatives", [](const Model& model, In<1> q, In<1> v, In<1> a, int f, int ref,
                                               nb::handle o0, nb::handle o1, nb::handle o2, nb::handle o3) {
        const Output outs[4] = {output_of(o0, 2), output_of(o1, 2), output_of(o2, 2), output_of(o3, 2)};
        require(length(q) == model.nq && length(v) == model.nv && length(a) == model.nv, "q, v, a: lengths");
        require(f >= 0 && f < model.nf && ref >= 0 && ref <= 2, "frame or reference out of range");
        require_rows_nv(outs, 4, 6, model.nv, "frame_acceleration_derivatives");
        core::frame_acceleration_derivatives(model, core::thread_data(model), core::thread_derivatives_data(model),
                                             q.data(), v.data(), a.data(), f, ref, outs[0].data(), outs[1].data(),
                                             outs[2].data(), outs[3].data());
    });
    m.def("center_of_mass_derivatives", [](const Model& model, In<1> q, In<1> v, nb::handle o0, nb::handle o1) {
        const Output outs[2] = {output_of(o0, 2), output_of(o1, 2)};
        require(length(q) == model.nq && length(v) == model.nv, "q, v: lengths");
        require_rows_nv(outs, 2, 3, model.nv, "center_of_mass_derivatives");
        core::center_of_mass_derivatives(model, core::thread_data(model), core::thread_derivatives_data(model),
                                         q.data(), v.data(), outs[0].data(), outs[1].data());
    });
}

}  // namespace bind
