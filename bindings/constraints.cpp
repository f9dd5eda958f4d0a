// Closed loops and coupled joints: the core's Constraints (built once from dynamics/constraints.py's flat arrays),
// their terms (phi, Phi_q, Phi_q_dot v) and the constrained forward dynamics, one state (exact float64 arrays,
// lengths and values checked here; None sends the caller to its general path) and batches (shapes checked again;
// the GIL released around the threads).
#include <algorithm>

#include "arrays.hpp"
#include "checks.hpp"
#include "constrained_derivatives.hpp"
#include "constrained_dynamics.hpp"
#include "constrained_inverse_dynamics.hpp"
#include "numpy.hpp"

namespace bind {

using core::Constraints;
using core::Model;

// Constraints checked against another model are refused (simulation.cpp too).
void require_model(const Constraints& c, const Model& model) {
    require(c.nb == model.nb && c.nq == model.nq && c.nv == model.nv,
            "constraints: built for another model (nbodies, nq or nv differ)");
}

namespace {

// The calling thread's workspace of the KKT solve (a worker of a batch has its own).
core::ConstrainedData& thread_constrained_data(const Model& model, const Constraints& con) {
    thread_local core::ConstrainedData cd;
    cd.resize(model, con);
    return cd;
}

// The calling thread's workspaces of the constrained inverse dynamics and of the derivatives (single calls).
core::ConstrainedInverseData& thread_inverse_data(const Model& model, const Constraints& con) {
    thread_local core::ConstrainedInverseData w;
    w.resize(model, con);
    return w;
}
core::ConstrainedDerivativesData& thread_constrained_derivatives_data(const Model& model, const Constraints& con) {
    thread_local core::ConstrainedDerivativesData w;
    w.resize(model, con);
    return w;
}

template <class A>
void require_out(const A& out, long B, std::initializer_list<long> shape, const char* name) {
    require(out.shape(0) == B, std::string(name) + ": the output has the wrong batch size");
    int d = 1;
    for (long n : shape) require(out.shape(d++) == n, std::string(name) + ": the output has the wrong shape");
}

using Ints2 = nb::ndarray<const int64_t, nb::ndim<2>, nb::c_contig, nb::device::cpu>;

int index(int64_t x, const char* name) {
    require(x >= -1 && x < (1 << 30), std::string("constraints: ") + name + " out of range");
    return static_cast<int>(x);
}

}  // namespace

void expose_constraints(nb::module_& m) {
    using namespace nb::literals;

    // kind, row (nc,), body (nc, 2), R (nc, 2, 3, 3), p (nc, 2, 3), idx (nc, 4), coef (nc, 2): ConstraintArrays
    nb::class_<Constraints>(m, "Constraints", "The core's constraints (core/constraints.hpp), built once from "
                                                  "dynamics.constraints.ConstraintArrays.")
        .def("__init__", [](Constraints* self, const Model& model, Ints kind, Ints row, Ints2 body, In<4> R, In<3> p,
                            Ints2 idx, In<2> coef, long m) {
            const size_t nc = kind.shape(0);
            require(row.shape(0) == nc && body.shape(0) == nc && body.shape(1) == 2 && R.shape(0) == nc &&
                        R.shape(1) == 2 && R.shape(2) == 3 && R.shape(3) == 3 && p.shape(0) == nc && p.shape(1) == 2 &&
                        p.shape(2) == 3 && idx.shape(0) == nc && idx.shape(1) == 4 && coef.shape(0) == nc &&
                        coef.shape(1) == 2,
                    "constraints: expected kind, row (nc,), body (nc, 2), R (nc, 2, 3, 3), p (nc, 2, 3), idx (nc, 4), "
                    "coef (nc, 2)");
            require(m >= 0 && m < (1 << 24), "constraints: m out of range");
            Constraints c;
            c.nc = static_cast<int>(nc), c.m = static_cast<int>(m);
            for (size_t k = 0; k < nc; ++k) {
                c.kind.push_back(index(kind(k), "kind")), c.row.push_back(index(row(k), "row"));
                for (int s = 0; s < 2; ++s) {
                    c.body.push_back(index(body(k, s), "body"));
                    core::Mat3 Rs;
                    for (int e = 0; e < 9; ++e) Rs[e] = R(k, s, e / 3, e % 3);
                    c.R.push_back(Rs);
                    c.p.push_back({p(k, s, 0), p(k, s, 1), p(k, s, 2)});
                    c.coef.push_back(coef(k, s));
                }
                for (int e = 0; e < 4; ++e) c.idx.push_back(index(idx(k, e), "idx"));
            }
            core::check(model, c);
            new (self) Constraints(std::move(c));
        }, "model"_a, "kind"_a, "row"_a, "body"_a, "R"_a, "p"_a, "idx"_a, "coef"_a, "m"_a)
        .def_ro("m", &Constraints::m)
        .def_ro("nc", &Constraints::nc);

    // one state: (a, lambda), or None when an input is not an exact float64 state of the right length with finite
    // values, or M is singular (the caller's general path then says what is wrong)
    m.def("constrained_forward_dynamics", [](const Model& model, const Constraints& c, nb::handle q, nb::handle v,
                                             nb::handle tau, double alpha, double beta) -> nb::object {
        require_model(c, model);
        const double *pq = vector_of(q, model.nq), *pv = vector_of(v, model.nv), *pt = vector_of(tau, model.nv);
        if (!pq || !pv || !pt || !core::configuration_ok(model, pq) || !core::all_finite(pv, model.nv) ||
            !core::all_finite(pt, model.nv) || !std::isfinite(alpha) || !std::isfinite(beta))
            return nb::none();
        double *a, *lam;
        nb::object A = new_array(model.nv, &a), L = new_array(c.m, &lam);
        core::ConstrainedData& cd = thread_constrained_data(model, c);
        if (core::constrained_forward_dynamics(model, c, core::thread_data(model), cd, pq, pv, pt, model.gravity,
                                               alpha, beta, a, lam) >= 0)
            return nb::none();
        return nb::make_tuple(A, L);
    }, "model"_a, "constraints"_a, "q"_a.none(), "v"_a.none(), "tau"_a.none(), "alpha"_a, "beta"_a);

    // out (B, nv + m): [a, lambda] per state
    m.def("constrained_forward_dynamics_batch", [](const Model& model, const Constraints& c, In<2> Q, In<2> V,
                                                   In<2> T, In<1> gravity, double alpha, double beta, nb::handle out_,
                                                   int nthreads, double seconds) {
        require_model(c, model);
        const Output out = output_of(out_, 2);
        const long B = length(out), nv = model.nv, n = nv + c.m;
        require_rows(Q, B, model.nq, "q"), require_rows(V, B, nv, "v"), require_rows(T, B, nv, "tau");
        require_out(out, B, {n}, "[a, lambda]");
        const core::Vec3 g = vec3(gravity, "gravity");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, core::Data& d) {
                double* o = out.data() + b * n;
                return core::constrained_forward_dynamics(model, c, d, thread_constrained_data(model, c),
                                                          row(Q, b), row(V, b), row(T, b), g, alpha, beta, o, o + nv);
            });
        }
        return status(s);
    });

    // out (B, nv): the torques of the actuated coordinates (actuated (nv): 1.0 there, 0.0 elsewhere) that produce
    // (q, v, a); a state that fails stops its chunk with code 1 (a violates the constraints) or 2 (the actuated
    // joints cannot produce it)
    m.def("constrained_inverse_dynamics_batch", [](const Model& model, const Constraints& c, In<2> Q, In<2> V,
                                                   In<2> A, In<1> gravity, In<1> actuated, nb::handle out_,
                                                   int nthreads, double seconds) {
        require_model(c, model);
        const Output out = output_of(out_, 2);
        const long B = length(out), nv = model.nv;
        require_rows(Q, B, model.nq, "q"), require_rows(V, B, nv, "v"), require_rows(A, B, nv, "a");
        require_out(out, B, {nv}, "tau");
        require(length(actuated) == nv, "actuated: expected " + std::to_string(nv) + " numbers");
        for (long k = 0; k < nv; ++k)
            require(actuated(k) == 0.0 || actuated(k) == 1.0, "actuated: expected 0.0 or 1.0 per coordinate");
        const core::Vec3 g = vec3(gravity, "gravity");
        std::vector<core::ConstrainedInverseData> work(std::max(1L, std::min<long>(std::max(nthreads, 1), B)));
        for (auto& w : work) w.resize(model, c);  // allocated here, not in a worker
        core::WorkspacePool<core::ConstrainedInverseData> pool(work);
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, core::Data& d) {
                const int code = core::constrained_inverse_dynamics(model, c, d, pool.of(d), row(Q, b), row(V, b),
                                                                    row(A, b), g, actuated.data(),
                                                                    out.data() + b * nv);
                return code == core::ID_DONE ? -1 : code;
            });
        }
        return status(s);
    });

    // one state: [da; dlam] along q, v and tau (3, nv + m, nv), or None when an input is not an exact
    // float64 state of the right length with finite values, the model has no constraints or M is singular (the
    // caller's general path then says what is wrong)
    m.def("constrained_forward_dynamics_derivatives", [](const Model& model, const Constraints& c, nb::handle q,
                                                         nb::handle v, nb::handle tau, double alpha,
                                                         double beta) -> nb::object {
        require_model(c, model);
        const double *pq = vector_of(q, model.nq), *pv = vector_of(v, model.nv), *pt = vector_of(tau, model.nv);
        if (c.m == 0 || !pq || !pv || !pt || !core::configuration_ok(model, pq) || !core::all_finite(pv, model.nv) ||
            !core::all_finite(pt, model.nv) || !std::isfinite(alpha) || !std::isfinite(beta))
            return nb::none();
        double* out;
        nb::object O = new_array(3, model.nv + c.m, model.nv, &out);
        if (core::constrained_forward_dynamics_derivatives(model, c, core::thread_data(model),
                                                           thread_constrained_derivatives_data(model, c), pq, pv, pt,
                                                           model.gravity, alpha, beta, out) >= 0)
            return nb::none();
        return O;
    }, "model"_a, "constraints"_a, "q"_a.none(), "v"_a.none(), "tau"_a.none(), "alpha"_a, "beta"_a);

    // out (B, 3, nv + m, nv): [da; dlam] along q, v and tau per state
    m.def("constrained_forward_dynamics_derivatives_batch", [](const Model& model, const Constraints& c, In<2> Q,
                                                               In<2> V, In<2> T, In<1> gravity, double alpha,
                                                               double beta, nb::handle out_, int nthreads,
                                                               double seconds) {
        require_model(c, model);
        require(c.m > 0, "constraints: none (the derivatives are those of a model with constraints)");
        require(std::isfinite(alpha) && std::isfinite(beta), "baumgarte: expected finite gains");
        const Output out = output_of(out_, 4);
        const long B = length(out), nv = model.nv, n = nv + c.m;
        require_rows(Q, B, model.nq, "q"), require_rows(V, B, nv, "v"), require_rows(T, B, nv, "tau");
        require_out(out, B, {3, n, nv}, "[da; dlam]");
        const core::Vec3 g = vec3(gravity, "gravity");
        std::vector<core::ConstrainedDerivativesData> work(std::max(1L, std::min<long>(std::max(nthreads, 1), B)));
        for (auto& w : work) w.resize(model, c);  // allocated here, not in a worker
        core::WorkspacePool<core::ConstrainedDerivativesData> pool(work);
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, core::Data& d) {
                return core::constrained_forward_dynamics_derivatives(model, c, d, pool.of(d), row(Q, b), row(V, b),
                                                                      row(T, b), g, alpha, beta,
                                                                      out.data() + b * 3 * n * nv);
            });
        }
        return status(s);
    });

    // what = 0: phi (out (B, m)), 1: Phi_q (out (B, m, nv)), 2: Phi_q_dot v (out (B, m)); V read only for 2
    m.def("constraint_terms_batch", [](const Model& model, const Constraints& c, In<2> Q, In<2> V, int what,
                                       nb::handle out_, int nthreads, double seconds) {
        require_model(c, model);
        require(what >= 0 && what <= 2, "what: 0 (phi), 1 (Phi_q) or 2 (Phi_q_dot v)");
        const Output out = output_of(out_, what == 1 ? 3 : 2);
        const long B = length(out), nv = model.nv, mm = c.m;
        require_rows(Q, B, model.nq, "q");
        if (what == 2) require_rows(V, B, nv, "v");
        if (what == 1) require_out(out, B, {mm, nv}, "Phi_q");
        else require_out(out, B, {mm}, what == 0 ? "phi" : "gamma");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, core::Data& d) {
                core::ConstrainedData& cd = thread_constrained_data(model, c);
                double* phi = what == 0 ? out.data() + b * mm : cd.phi.data();
                double* J = what == 1 ? out.data() + b * mm * nv : nullptr;
                double* gamma = what == 2 ? out.data() + b * mm : nullptr;
                core::constraint_terms(model, c, d, cd.w, row(Q, b), what == 2 ? row(V, b) : nullptr, phi, J,
                                       gamma);
                return -1;
            });
        }
        return status(s);
    });

    // q_out (nq): q moved onto phi = 0 by Gauss-Newton (at most max_iter steps); returns max |phi(q_out)|
    m.def("project_position", [](const Model& model, const Constraints& c, In<1> q, double tol, int max_iter,
                                 nb::handle out_) {
        require_model(c, model);
        const Output out = output_of(out_, 1);
        require(length(q) == model.nq && length(out) == model.nq, "q, q_out: expected (nq,)");
        require(core::configuration_ok(model, q.data()), "q: expected a finite configuration");
        require(max_iter >= 0 && max_iter <= 10000, "max_iter: expected 0 to 10000");
        core::ConstrainedData& cd = thread_constrained_data(model, c);
        return core::project_position(model, c, core::thread_data(model), cd, q.data(), tol, max_iter, out.data());
    }, "model"_a, "constraints"_a, "q"_a, "tol"_a, "max_iter"_a, "q_out"_a);

    // (max |phi(q)|, max |Phi_q v|): the position and velocity residuals of one state (a simulation's drift)
    m.def("constraint_drift", [](const Model& model, const Constraints& c, In<1> q, In<1> v) {
        require_model(c, model);
        require(length(q) == model.nq && length(v) == model.nv, "q, v: expected (nq,) and (nv,)");
        require(core::configuration_ok(model, q.data()) && core::all_finite(v.data(), model.nv),
                "q, v: expected a finite configuration and velocity");
        double position, velocity;
        core::constraint_drift(model, c, core::thread_data(model), thread_constrained_data(model, c), q.data(),
                               v.data(), position, velocity);
        return nb::make_tuple(position, velocity);
    }, "model"_a, "constraints"_a, "q"_a, "v"_a);

    // out (B, nv): the velocity nearest v with Phi_q v = 0 (kinetic-energy metric)
    m.def("project_velocity_batch", [](const Model& model, const Constraints& c, In<2> Q, In<2> V,
                                       nb::handle out_, int nthreads, double seconds) {
        require_model(c, model);
        const Output out = output_of(out_, 2);
        const long B = length(out), nv = model.nv;
        require_rows(Q, B, model.nq, "q"), require_rows(V, B, nv, "v"), require_out(out, B, {nv}, "v");
        core::BatchStatus s;
        {
            nb::gil_scoped_release unlocked;
            s = core::run_batch(model, B, nthreads, seconds, [&](long b, core::Data& d) {
                return core::project_velocity(model, c, d, thread_constrained_data(model, c), row(Q, b),
                                              row(V, b), out.data() + b * nv);
            });
        }
        return status(s);
    });
}

}  // namespace bind
