// The simulation's run: the passive torques, the torque source (a Python callable called back with the GIL taken)
// and one run of a method over the robot problem, writing into arrays the Python side owns (the samples, the
// statistics record, the switch log), the GIL released for the whole loop.
#include <nanobind/stl/string.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "arrays.hpp"
#include "configuration.hpp"
#include "contact/contact_model.hpp"
#include "control/passive.hpp"
#include "control/sources.hpp"
#include "numpy.hpp"
#include "py_torque.hpp"
#include "run_args.hpp"
#include "simulation/constrained_problem.hpp"
#include "simulation/robot_problem.hpp"
#include "simulation/sensitivities.hpp"

namespace bind {

using core::Model;

void require_model(const core::Constraints& c, const Model& model);  // bindings/constraints.cpp
core::contact::ContactModel& contact_of(nb::handle x, const Model& model);  // bindings/contact_model.cpp

namespace {

template <class A>
std::vector<double> copy_of(const A& a) {
    return std::vector<double>(a.data(), a.data() + a.size());
}

// The source and its callback, kept together (the source points at the callback), and the model it was made for
// (its address and sizes: bindings/control.cpp refuses a source of another model).
struct SourceHolder {
    core::control::Source source;
    std::unique_ptr<PyTorque> callback;
    const Model* model = nullptr;
    int nq = -1, nv = -1, nb = -1, nf = -1;
};

// A (1,) int64 array: the count of samples, read by the progress bar while the run goes.
int64_t* int_output(nb::handle x, const char* name) {
    nb::ndarray<int64_t, nb::shape<1>, nb::c_contig, nb::device::cpu> a;
    if (!nb::try_cast(x, a, false)) throw nb::type_error((std::string(name) + ": expected a (1,) int64 array").c_str());
    return a.data();
}

}  // namespace

// The holder's core source (bindings/control.cpp), checked to be made for `model`.
core::control::Source& source_of(nb::handle x, const Model& model) {
    SourceHolder* h = nullptr;
    if (!nb::try_cast(x, h) || !h) throw nb::type_error("source: expected a _core.Source");
    require(h->model == &model && h->nq == model.nq && h->nv == model.nv && h->nb == model.nb && h->nf == model.nf,
            "source: made for another model");
    return h->source;
}

// Raise the exception a source's Python callable kept, if any.
void raise_source_error(nb::handle x) {
    SourceHolder* h = nullptr;
    if (nb::try_cast(x, h) && h && h->callback) h->callback->raise_if_failed();
}

// The passive torques' parameters, checked to fit `model` (their sizes and q indices).
void require_passive(const core::control::Passive& p, const Model& model) {
    const size_t nv = model.nv;
    bool ok = p.damping.size() == nv && p.friction.size() == nv && p.lower.size() == nv && p.upper.size() == nv &&
              p.qpos.size() == nv;
    for (size_t k = 0; ok && k < nv; ++k) ok = p.qpos[k] >= -1 && p.qpos[k] < model.nq;
    require(ok, "passive: made for another model");
}

namespace {

// The report's numbers computed in one core pass each (dynamics/simulation/report.py).
void expose_report_terms(nb::module_& m) {
    using namespace nb::literals;
    // The energy balance's terms over a run's samples (dynamics/simulation/report.py, energy_balance): e (T, 2) the
    // kinetic and potential energies, w (T, nquad) the works.  Returns (max K, max U - min U, max_k |w_Tk|, r_T,
    // max_i r_i, E_0, E_T) with E = K + U, W_i = (w_i0 + w_i1) (+ w_i2) and r_i = |(E_i - E_0) - W_i|: numpy's
    // elementwise operations and its row sum in its order, and its rule for a max or min (a NaN anywhere is the
    // result), so the same numbers as numpy's, in one pass instead of a dozen numpy calls.
    m.def("energy_balance_terms", [](In<2> e, In<2> w) {
        const long T = length(e), nq = static_cast<long>(w.shape(1));
        require(T >= 1 && e.shape(1) == 2 && length(w) == T && nq >= 1, "energy_balance_terms: e (T, 2), w (T, nquad)");
        const double *E2 = e.data(), *W = w.data();
        // numpy's maximum and minimum: (a >= x || isnan(a)) ? a : x, the accumulator a first
        auto max = [](double a, double x) { return a >= x || std::isnan(a) ? a : x; };
        auto min = [](double a, double x) { return a <= x || std::isnan(a) ? a : x; };
        auto work = [&](long i) {
            double s = W[i * nq];
            for (long k = 1; k < nq; ++k) s += W[i * nq + k];
            return s;
        };
        const double e0 = E2[0] + E2[1];
        double k_max = E2[0], u_max = E2[1], u_min = E2[1], r = std::abs((e0 - e0) - work(0)), r_max = r;
        for (long i = 1; i < T; ++i) {
            const double K = E2[2 * i], U = E2[2 * i + 1];
            k_max = max(k_max, K), u_max = max(u_max, U), u_min = min(u_min, U);
            r = std::abs((K + U - e0) - work(i));
            r_max = max(r_max, r);
        }
        const double* wl = W + (T - 1) * nq;
        double w_max = std::abs(wl[0]);
        for (long k = 1; k < nq; ++k) w_max = max(w_max, std::abs(wl[k]));
        const double e_last = E2[2 * (T - 1)] + E2[2 * (T - 1) + 1];
        return nb::make_tuple(k_max, u_max - u_min, w_max, r, r_max, e0, e_last);
    }, "e"_a, "w"_a);

    // (max_k |difference(q2, q1)_k|, max_k |v1_k - v2_k|): dynamics.simulation.state_error's numbers (numpy's max
    // with initial 0: a NaN anywhere is the result), for the error estimate's comparison of two final states.
    m.def("state_error", [](const Model& model, In<1> q1, In<1> v1, In<1> q2, In<1> v2) {
        require(length(q1) == model.nq && length(q2) == model.nq && length(v1) == model.nv && length(v2) == model.nv,
                "state_error: q (nq,), v (nv,)");
        std::vector<double> d(model.nv);
        core::difference(model, q2.data(), q1.data(), d.data());
        auto max = [](double a, double x) { return a >= x || std::isnan(a) ? a : x; };
        double eq = 0.0, ev = 0.0;
        for (long k = 0; k < model.nv; ++k) {
            eq = max(eq, std::abs(d[k]));
            ev = max(ev, std::abs(v1.data()[k] - v2.data()[k]));
        }
        return nb::make_tuple(eq, ev);
    }, "model"_a, "q1"_a, "v1"_a, "q2"_a, "v2"_a);
}

}  // namespace

void expose_simulation(nb::module_& m) {
    using namespace nb::literals;
    namespace control = core::control;

    nb::class_<control::Passive>(m, "Passive")
        .def("__init__", [](control::Passive* self, const Model& model, In<1> damping, In<1> friction,
                            double friction_eps, bool limits, In<1> lower, In<1> upper, Ints qpos, double k_limit,
                            double b_limit, In<1> gravity) {
            const long nv = model.nv;
            for (auto* a : {&damping, &friction, &lower, &upper}) require(length(*a) == nv, "passive: (nv,) arrays");
            require(length(qpos) == nv, "passive: qpos (nv,)");
            control::Passive p;
            p.damping = copy_of(damping), p.friction = copy_of(friction), p.friction_eps = friction_eps;
            p.limits = limits, p.lower = copy_of(lower), p.upper = copy_of(upper);
            for (long k = 0; k < nv; ++k) {
                require(qpos(k) >= -1 && qpos(k) < model.nq, "passive: qpos out of range");
                p.qpos.push_back(static_cast<int>(qpos(k)));
            }
            p.k_limit = k_limit, p.b_limit = b_limit, p.gravity = vec3(gravity, "gravity");
            require(friction_eps > 0, "passive: friction_eps > 0");
            new (self) control::Passive(std::move(p));
        });

    nb::class_<SourceHolder>(m, "Source")
        .def("__init__", [](SourceHolder* self, const Model& model, int kind, In<1> times, In<2> table, In<2> gains,
                            In<1> qref, long frame, Ints rows, In<2> task_gains, In<2> orientation, double damping,
                            nb::object callback, nb::object check) {
            new (self) SourceHolder();
            self->model = &model, self->nq = model.nq, self->nv = model.nv, self->nb = model.nb, self->nf = model.nf;
            control::Source& s = self->source;
            require(kind >= control::ZERO && kind <= control::OPERATIONAL_SPACE, "source: unknown kind");
            const long N = length(times), nv = model.nv;
            require(N >= 1 && static_cast<long>(table.shape(0)) == N, "source: times and table rows");
            require(gains.shape(0) == 4 && static_cast<long>(gains.shape(1)) == nv, "source: gains (4, nv)");
            require(length(qref) == model.nq, "source: qref (nq,)");
            const long cols = static_cast<long>(table.shape(1));
            if (kind == control::TABLE_LINEAR || kind == control::TABLE_ZOH) require(cols == nv, "source: table (N, nv)");
            if (kind == control::COMPUTED_TORQUE) require(cols == 3 * nv && model.nq == nv, "source: reference (N, 3 nv)");
            s.kind = kind, s.times = copy_of(times), s.table = copy_of(table), s.table_cols = static_cast<int>(cols);
            s.gains = copy_of(gains), s.qref = copy_of(qref);
            if (kind == control::OPERATIONAL_SPACE) {
                require(frame >= 0 && frame < model.nf, "source: frame out of range");
                require(cols == 9, "source: task reference (N, 9)");
                require(task_gains.shape(0) == 2 && task_gains.shape(1) == 6, "source: task gains (2, 6)");
                require(static_cast<long>(orientation.shape(0)) == N && orientation.shape(1) == 12, "source: orientation (N, 12)");
                require(length(rows) >= 1 && length(rows) <= 6, "source: 1 to 6 task rows");
                s.frame = static_cast<int>(frame);
                for (size_t k = 0; k < rows.shape(0); ++k) {
                    require(rows(k) >= 0 && rows(k) < 6, "source: rows in [0, 6)");
                    s.rows.push_back(static_cast<int>(rows(k)));
                }
                for (int r = 0; r < 2; ++r)
                    for (int c = 0; c < 6; ++c) s.task_gains[r][c] = task_gains(r, c);
                s.orientation = copy_of(orientation), s.damping = damping;
            }
            if (kind == control::CALLABLE) {
                require(!callback.is_none(), "source: a callable");
                self->callback = std::make_unique<PyTorque>(callback, check, model.nq, model.nv);
                s.callback = self->callback.get();
            }
        }, "model"_a, "kind"_a, "times"_a, "table"_a, "gains"_a, "qref"_a, "frame"_a, "rows"_a, "task_gains"_a,
           "orientation"_a, "damping"_a, "callback"_a.none(), "check"_a.none());

    expose_report_terms(m);

    // f(t, z) into dz and the robot problem's analytical Jacobian df/dz into J ((n, n), n = 2 nv + 2, + 1 with
    // contact; z = [delta, v, W_source, W_passive (, W_contact)] in the chart around q0): a test's window onto the
    // core's Jacobian (tests/test_simulation_jacobian_core.py).  Returns False when the problem has none (J untouched).
    m.def("problem_jacobian", [](const Model& model, const control::Passive& passive, SourceHolder& src, In<1> q0,
                                 In<1> z, double t, nb::handle dz_, nb::handle J_, nb::object contact_) {
        core::contact::ContactModel* contact = contact_.is_none() ? nullptr : &contact_of(contact_, model);
        const long nv = model.nv, n = 2 * nv + (contact ? 3 : 2);
        const Output dz = output_of(dz_, 1), J = output_of(J_, 2);
        require(length(q0) == model.nq, "q0: (nq,)");
        require(length(z) == n && length(dz) == n, "z, dz: (2 nv + 2,), + 1 with contact");
        require(length(J) == n && static_cast<long>(J.shape(1)) == n, "J: (n, n)");
        core::sim::RobotProblem p(model, passive, src.source, q0.data(), core::sim::Outputs{}, contact);
        core::sim::Stats st;
        p.rhs(t, z.data(), dz.data());
        const bool analytical = p.jacobian(t, z.data(), dz.data(), nullptr, static_cast<int>(n), J.data(), st);
        if (src.callback) src.callback->raise_if_failed();
        return analytical;
    }, "model"_a, "passive"_a, "source"_a, "q0"_a, "z"_a, "t"_a, "dz"_a, "J"_a, "contact"_a.none() = nb::none());

    // One run of `method` from (t0, z) to t_end (z advanced in place); the samples at out_t into the outputs (rows
    // 0 for what is not kept); the statistics into `stats` (a (1,) STATS record array) and the switches into `sw`
    // (a SWITCH record array of MAX_SWITCHES rows).  Raises a Python callable's exception after the run.
    m.def("run", [](const std::string& method, const Model& model, const control::Passive& passive, SourceHolder& src,
                    In<1> q0, nb::handle z_, double t0, double t_end, nb::handle out_t_, nb::handle out_q_,
                    nb::handle out_v_, nb::handle out_tau_, nb::handle out_w_, nb::handle out_e_, nb::handle count_,
                    nb::handle opt_, nb::handle stats_, nb::handle sw_, nb::object sens, nb::object constrained,
                    nb::object contact_) {
        core::contact::ContactModel* contact = contact_.is_none() ? nullptr : &contact_of(contact_, model);
        const long nquad = contact ? 3 : 2;  // W_source, W_passive (, W_contact)
        const Output z = output_of(z_, 1), out_t = output_of(out_t_, 1), oq = output_of(out_q_, 2);
        const Output ov = output_of(out_v_, 2), otau = output_of(out_tau_, 2), ow = output_of(out_w_, 2);
        const Output oe = output_of(out_e_, 2);
        const long T = length(out_t), nq = model.nq, nv = model.nv, n = length(z);
        require(length(q0) == nq, "q0: (nq,)");
        require(oq.shape(1) == nq && (length(oq) == T || length(oq) == 0), "out_q: (T or 0, nq)");
        require(ov.shape(1) == nv && (length(ov) == T || length(ov) == 0), "out_v: (T or 0, nv)");
        require(otau.shape(1) == nv && (length(otau) == T || length(otau) == 0), "out_tau: (T or 0, nv)");
        require(length(ow) == T && ow.shape(1) == nquad && length(oe) == T && oe.shape(1) == 2,
                "out_w: (T, 2, or 3 with contact), out_e: (T, 2)");
        // sensitivities: (x0, params (P, 3) int64, out_S (T or 0, 2 nv, ncol), Sf (2 nv, ncol)), or None
        bool x0 = false;
        std::vector<int> params;
        Output oS, Sf;
        long ncol = 0;
        if (!sens.is_none()) {
            nb::tuple t = nb::cast<nb::tuple>(sens);
            require(t.size() == 4, "sensitivities: (x0, params, out_S, Sf)");
            x0 = nb::cast<bool>(t[0]);
            nb::ndarray<const int64_t, nb::ndim<2>, nb::c_contig, nb::device::cpu> P;
            if (!nb::try_cast(t[1], P, false) || (P.shape(0) > 0 && P.shape(1) != 3))
                throw nb::type_error("sensitivities: params (P, 3) int64");
            oS = output_of(t[2], 3), Sf = output_of(t[3], 2);
            ncol = (x0 ? 2 * nv : 0) + static_cast<long>(P.shape(0));
            for (size_t j = 0; j < P.shape(0); ++j) {
                const long place = P(j, 0), row = P(j, 1), col = P(j, 2);
                const auto& sc = src.source;
                bool ok = (place == core::sim::GAINS && row >= 0 && row < 4 && col >= 0 && col < nv) ||
                          (place == core::sim::QREF && col >= 0 && col < nq) ||
                          (place == core::sim::TABLE && row >= 0 && row < sc.samples() && col >= 0 && col < sc.table_cols);
                require(ok, "sensitivities: a parameter out of the source's range");
                params.insert(params.end(), {static_cast<int>(place), static_cast<int>(row), static_cast<int>(col)});
            }
            require(oS.shape(1) == 2 * nv && oS.shape(2) == ncol && (length(oS) == T || length(oS) == 0),
                    "out_S: (T or 0, 2 nv, ncol)");
            require(length(Sf) == 2 * nv && Sf.shape(1) == ncol, "Sf: (2 nv, ncol)");
        }
        require(n == 2 * nv + nquad + 2 * nv * ncol, "z: (2 nv (1 + ncol) + 2, or + 3 with contact)");
        core::sim::Outputs out;
        out.t = out_t.data(), out.T = T, out.q = oq.data(), out.v = ov.data(), out.tau = otau.data();
        out.keep_q = length(oq) == T && T > 0, out.keep_v = length(ov) == T && T > 0, out.keep_tau = length(otau) == T && T > 0;
        out.w = ow.data(), out.e = oe.data(), out.count = int_output(count_, "count");
        auto [stats_raw, stats_ptr] = record_of(stats_, sizeof(core::sim::Stats), "stats");
        auto [sw_raw, sw_ptr] = record_of(sw_, sizeof(core::sim::Switch) * core::sim::MAX_SWITCHES, "switches");
        const core::sim::Options opt = options_of(opt_);
        require(opt.nc == nv && opt.nvel == nv && opt.ne >= 0 && opt.ne <= n, "options: sizes");
        core::sim::Stats st;
        std::vector<core::sim::Switch> sw;
        std::memcpy(&st, stats_ptr, sizeof st);  // a resumed run goes on from its statistics
        // a constrained model: (constraints, alpha, beta, project, out_lam (T or 0, m), drift (3,): max |phi|,
        // max |Phi_q v|, failed projections), or None
        const core::Constraints* pcon = nullptr;
        double alpha = 0.0, beta = 0.0;
        bool project = false;
        double *lam_out = nullptr, *drift_out = nullptr;
        if (!constrained.is_none()) {
            const char* what = "constrained: (constraints, alpha, beta, project, out_lam, drift)";
            nb::tuple c;
            if (!nb::try_cast(constrained, c) || c.size() != 6) throw nb::type_error(what);
            if (!nb::try_cast(c[0], pcon) || !pcon || !nb::try_cast(c[1], alpha, false) ||
                !nb::try_cast(c[2], beta, false) || !nb::try_cast(c[3], project, false))
                throw nb::type_error(what);
            require_model(*pcon, model);
            require(std::isfinite(alpha) && std::isfinite(beta), "constrained: finite Baumgarte gains");
            const Output lam = output_of(c[4], 2), drift = output_of(c[5], 1);
            require(lam.shape(1) == pcon->m && (length(lam) == T || length(lam) == 0), "out_lam: (T or 0, m)");
            require(length(drift) == 3, "drift: (3,)");
            lam_out = length(lam) && T ? lam.data() : nullptr, drift_out = drift.data();
        }
        // the problem is made (its workspaces allocated) and run without the GIL: it reads only the core's objects
        // and the arrays held above, and other threads' simulations go on meanwhile
        std::unique_ptr<core::sim::RobotProblem> robot;
        std::unique_ptr<core::sim::SensitivityProblem> ps;
        {
            nb::gil_scoped_release unlocked;
            if (pcon)
                robot = std::make_unique<core::sim::ConstrainedProblem>(model, *pcon, passive, src.source, q0.data(),
                                                                        out, alpha, beta, project, lam_out, drift_out,
                                                                        contact);
            else
                robot = std::make_unique<core::sim::RobotProblem>(model, passive, src.source, q0.data(), out, contact);
            if (!sens.is_none())  // (is_none reads only the handle: no reference count touched)
                ps = std::make_unique<core::sim::SensitivityProblem>(*robot, x0, params, length(oS) ? oS.data() : nullptr,
                                                                     Sf.data());
            core::sim::Problem& run_p = ps ? static_cast<core::sim::Problem&>(*ps) : *robot;
            core::sim::run_method(method.c_str(), run_p, z.data(), static_cast<int>(n), t0, t_end, out_t.data(), T,
                                  opt, st, sw);
            if (ps) ps->final(z.data(), Sf.data());
        }
        core::sim::RobotProblem& p = *robot;
        std::memcpy(stats_ptr, &st, sizeof st);
        if (!sw.empty())  // (memcpy from an empty vector's null data() is undefined even for 0 bytes)
            std::memcpy(sw_ptr, sw.data(), sizeof(core::sim::Switch) * std::min<size_t>(sw.size(), core::sim::MAX_SWITCHES));
        if (src.callback) src.callback->raise_if_failed();
        double* qb;
        nb::object qbase = new_array(nq, &qb);
        std::copy(p.base(), p.base() + nq, qb);
        return qbase;  // the chart's base at the end: the final q is retract(base, z[:nv])
    }, "method"_a, "model"_a, "passive"_a, "source"_a, "q0"_a, "z"_a, "t0"_a, "t_end"_a, "out_t"_a, "out_q"_a,
       "out_v"_a, "out_tau"_a, "out_w"_a, "out_e"_a, "count"_a, "options"_a, "stats"_a, "switches"_a,
       "sensitivities"_a.none(), "constrained"_a.none() = nb::none(), "contact"_a.none() = nb::none());
}

}  // namespace bind
