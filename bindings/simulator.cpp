// A simulation stepped from the caller's loop (core/simulation/simulator.hpp) as the Python object _core.Simulator:
// N environments of one model made from the run's parts (the passive torques, the torque source, a contact model
// per environment, the constraints) and the arrays dynamics.Simulator owns and shows (time, q, v, the carried step
// and phase, the status, the error estimate, the work and energies, the counters), every shape checked here before
// the core holds a pointer into it.  step() releases the GIL for the whole batch; a Python torque is called back
// with it taken (the environments are then stepped one after another).
#include <nanobind/stl/string.h>

#include <algorithm>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "contact/contact_model.hpp"
#include "control/passive.hpp"
#include "control/sources.hpp"
#include "numpy.hpp"
#include "py_torque.hpp"
#include "simulation/constrained_problem.hpp"
#include "simulation/simulator.hpp"

namespace bind {

using core::Model;
namespace control = core::control;
namespace sim = core::sim;

void require_model(const core::Constraints& c, const Model& model);               // bindings/constraints.cpp
core::contact::ContactModel& contact_of(nb::handle x, const Model& model);          // bindings/contact_model.cpp
control::Source& source_of(nb::handle x, const Model& model);                       // bindings/simulation.cpp

namespace {

template <class T, size_t N>
using Out = nb::ndarray<T, nb::ndim<N>, nb::c_contig, nb::device::cpu>;

// An array the core writes into for the simulator's life: exactly that dtype and rank, C-contiguous, writable,
// `rows` rows of `cols` columns (cols < 0: a 1-d array).
template <class T, size_t N>
Out<T, N> held_array(nb::handle x, const char* name, long rows, long cols) {
    Out<T, N> a;
    const bool typed = nb::try_cast(x, a, false);
    const bool shaped = typed && static_cast<long>(a.shape(0)) == rows && (N == 1 || static_cast<long>(a.shape(1)) == cols);
    if (!shaped)
        throw std::invalid_argument(std::string(name) + ": expected a writable C-contiguous " +
                                    (std::is_same_v<T, double> ? "float64" : "int64") + " array of " +
                                    std::to_string(rows) + (N == 1 ? "" : " x " + std::to_string(cols)) + " entries");
    return a;
}

// What the environments point into, at a fixed address for the simulator's life.
struct Parts {
    nb::object keep;  // the model's core, the contact models, the constraints and the arrays
    const Model* model = nullptr;
    control::Passive passive;
    control::Source source;
    std::unique_ptr<PyTorque> callback;
    sim::StepSettings settings;
    std::vector<sim::Environment> envs;
    Out<double, 2> tau;  // (N, nv): zeros, the held torque of a step given none
    std::mutex busy;     // one step or load at a time (dynamics.Simulator takes turns before it gets here)
    std::vector<double> shadow_drift;  // (N, 3): a constrained shadow's drift, read by nobody
};

struct SimulatorHolder {
    std::unique_ptr<Parts> parts;
};

// The arrays' rows as one environment's EnvArrays.
struct Arrays {
    Out<double, 1> t, h, error;
    Out<double, 2> q, v, w, drift, clock;
    Out<int64_t, 1> phase, status, count;
    Out<int64_t, 2> counters;
    sim::EnvArrays row(long i) {
        sim::EnvArrays a;
        a.t = t.data() + i, a.q = q.data() + i * q.shape(1), a.v = v.data() + i * v.shape(1);
        a.h = h.data() + i, a.phase = phase.data() + i, a.status = status.data() + i, a.error = error.data() + i;
        a.w = w.data() + i * w.shape(1), a.count = count.data() + i;
        a.counters = counters.data() + 4 * i, a.clock = clock.data() + 2 * i;
        return a;
    }
};

Arrays arrays_of(const nb::dict& d, long N, const Model& model, long nquad, bool constrained) {
    Arrays a;
    a.t = held_array<double, 1>(d["t"], "t", N, -1), a.h = held_array<double, 1>(d["h"], "h", N, -1);
    a.error = held_array<double, 1>(d["error"], "error", N, -1);
    a.q = held_array<double, 2>(d["q"], "q", N, model.nq), a.v = held_array<double, 2>(d["v"], "v", N, model.nv);
    a.w = held_array<double, 2>(d["w"], "w", N, nquad);
    a.drift = held_array<double, 2>(d["drift"], "drift", constrained ? N : 0, 3);
    a.clock = held_array<double, 2>(d["clock"], "clock", N, 2);
    a.phase = held_array<int64_t, 1>(d["phase"], "phase", N, -1);
    a.status = held_array<int64_t, 1>(d["status"], "status", N, -1);
    a.count = held_array<int64_t, 1>(d["count"], "count", N, -1);
    a.counters = held_array<int64_t, 2>(d["counters"], "counters", N, 4);
    return a;
}

// The settings of every period from the dict dynamics.Simulator makes.
sim::StepSettings settings_of(const nb::dict& d, const Model& model, long nquad) {
    sim::StepSettings s;
    s.method = nb::cast<std::string>(d["method"]);
    s.fixed = s.method == "euler" || s.method == "implicit_euler" || s.method == "rk4";
    require(s.fixed || s.method == "rk45" || s.method == "dop853" || s.method == "radau" || s.method == "auto",
            "method: one of euler, implicit_euler, rk4, rk45, dop853, radau, auto");
    s.dt = nb::cast<double>(d["dt"]), s.substep = nb::cast<double>(d["substep"]);
    require(std::isfinite(s.dt) && s.dt > 0, "dt: a finite period > 0");
    require(!s.fixed || (std::isfinite(s.substep) && s.substep > 0 && s.dt / s.substep <= 1e9),
            "substep: a finite step > 0, at most 1e9 per period");
    s.opt.nc = model.nv, s.opt.nvel = model.nv, s.opt.ne = 2 * model.nv;
    s.opt.rtol = nb::cast<double>(d["rtol"]), s.opt.atol = nb::cast<double>(d["atol"]);
    s.rerun = nb::cast<bool>(d["rerun"]), s.order = nb::cast<int>(d["order"]);
    require(s.order >= 0 && s.order <= 8, "order: the method's order, 0 to 8");
    s.opt.max_steps = nb::cast<int64_t>(d["max_steps"]), s.opt.blowup = nb::cast<double>(d["blowup"]);
    s.opt.hmax = 1e300;
    require(s.opt.rtol > 0 && s.opt.atol >= 0 && s.opt.max_steps >= 1, "rtol > 0, atol >= 0, max_steps >= 1");
    (void)nquad;
    return s;
}

// One distinct contact model per environment, then one per shadow of the error estimate's rerun (N or 2 N), lean
// unless auto needs touchdown(); all null without contact.
std::vector<core::contact::ContactModel*> contact_models(nb::object contacts, const Model& model, long N,
                                                         const sim::StepSettings& s) {
    const long nc = s.rerun ? 2 * N : N;
    std::vector<core::contact::ContactModel*> cms(nc, nullptr);
    if (contacts.is_none()) return cms;
    nb::list l = nb::cast<nb::list>(contacts);
    require(static_cast<long>(nb::len(l)) == nc, "contacts: one contact model per environment (and shadow)");
    for (long i = 0; i < nc; ++i) cms[i] = &contact_of(l[i], model);
    std::vector<core::contact::ContactModel*> sorted(cms);
    std::sort(sorted.begin(), sorted.end());
    require(std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end(),
            "contacts: one contact model per environment (and shadow)");
    for (long i = 0; i < nc; ++i) cms[i]->set_lean(s.method != "auto");  // nothing here reads the report's tracking
    return cms;
}

// The parts and environments of a simulator, every argument checked before any environment is made.
std::unique_ptr<Parts> make_parts(nb::handle model_, const control::Passive& passive, nb::handle source,
                                  nb::object callback, nb::object check, nb::object contacts, nb::object constrained,
                                  const nb::dict& settings, const nb::dict& arrays) {
    const Model* pm = nullptr;
    if (!nb::try_cast(model_, pm) || !pm) throw nb::type_error("model: expected the model's core");
    const Model& model = *pm;
    auto P = std::make_unique<Parts>();
    P->model = pm;
    P->passive = passive;
    P->source = source_of(source, model);
    const long nquad = contacts.is_none() ? 2 : 3;
    P->settings = settings_of(settings, model, nquad);
    const long N = static_cast<long>(nb::len(nb::object(arrays["t"])));
    require(N >= 1, "environments: at least one");
    Arrays a = arrays_of(arrays, N, model, nquad, !constrained.is_none());
    if (P->source.kind == control::CALLABLE) {
        require(!callback.is_none() && !check.is_none(), "torque: a callable and its check");
        P->callback = std::make_unique<PyTorque>(callback, check, model.nq, model.nv);
        P->source.callback = P->callback.get();
    }
    std::vector<core::contact::ContactModel*> cms = contact_models(contacts, model, N, P->settings);
    core::contact::ContactModel** shadows = cms.data() + N;
    const core::Constraints* con = nullptr;
    double alpha = 0.0, beta = 0.0;
    bool project = false;
    if (!constrained.is_none()) {
        nb::tuple c = nb::cast<nb::tuple>(constrained);
        require(c.size() == 4, "constrained: (constraints, alpha, beta, project)");
        if (!nb::try_cast(c[0], con) || !con) throw nb::type_error("constrained: the model's core constraints");
        require_model(*con, model);
        alpha = nb::cast<double>(c[1]), beta = nb::cast<double>(c[2]), project = nb::cast<bool>(c[3]);
        require(std::isfinite(alpha) && std::isfinite(beta), "constrained: finite Baumgarte gains");
    }
    P->tau = held_array<double, 2>(arrays["tau"], "tau", N, model.nv);
    // the objects themselves, not the dict and list they came in (a later assignment there must not free them)
    nb::list held;
    for (const char* k : {"t", "q", "v", "h", "phase", "status", "error", "w", "count", "counters", "drift", "clock", "tau"})
        held.append(arrays[k]);
    P->keep = nb::make_tuple(model_, contacts.is_none() ? nb::object(nb::none()) : nb::object(nb::tuple(contacts)),
                             constrained, nb::tuple(held));
    auto problem = [&](const sim::Outputs& out, const double* q0, double* drift, core::contact::ContactModel* c) {
        std::unique_ptr<sim::RobotProblem> p;
        if (con)
            p = std::make_unique<sim::ConstrainedProblem>(model, *con, P->passive, P->source, q0, out, alpha, beta,
                                                          project, nullptr, drift, c);
        else
            p = std::make_unique<sim::RobotProblem>(model, P->passive, P->source, q0, out, c);
        return p;
    };
    P->shadow_drift.assign(P->settings.rerun ? 3 * N : 0, 0.0);
    P->envs.reserve(N);
    for (long i = 0; i < N; ++i) {
        sim::EnvArrays e = a.row(i);
        sim::Outputs out;
        out.t = e.t, out.T = 1, out.q = e.q, out.v = e.v, out.keep_q = true, out.keep_v = true;
        out.w = e.w, out.count = e.count;  // (no energies: dynamics.Simulator.energy computes them when read)
        P->envs.emplace_back(problem(out, e.q, con ? a.drift.data() + 3 * i : nullptr, cms[i]), e);
        if (P->settings.rerun) {
            sim::Environment& env = P->envs.back();
            env.set_shadow(problem(env.shadow_outputs(), e.q, con ? &P->shadow_drift[3 * i] : nullptr, shadows[i]));
        }
    }
    return P;
}

}  // namespace

void expose_simulator(nb::module_& m) {
    using namespace nb::literals;
    nb::class_<SimulatorHolder>(m, "Simulator", "Environments stepped from the caller's loop (core/simulation/simulator.hpp).")
        .def("__init__", [](SimulatorHolder* self, nb::handle model, const control::Passive& passive,
                            nb::handle source, nb::object callback, nb::object check, nb::object contacts,
                            nb::object constrained, nb::dict settings, nb::dict arrays) {
            auto parts = make_parts(model, passive, source, callback, check, contacts, constrained, settings, arrays);
            new (self) SimulatorHolder{std::move(parts)};
        }, "model"_a, "passive"_a, "source"_a, "callback"_a.none(), "check"_a.none(), "contacts"_a.none(),
           "constrained"_a.none(), "settings"_a, "arrays"_a)
        // One period for every environment that is ready, under the held torques in the "tau" array (N, nv), copied
        // first from `tau` when given: exactly a float64 C-contiguous array of N nv numbers, or nv for every
        // environment (the fast path of a loop's numpy torques).  Returns (failed now, skipped, expired, the first
        // non-finite torque's flat index or -1; -2: `tau` not taken, the caller copies it itself; nothing was
        // stepped when >= 0 or -2).  Raises a Python torque's exception after the batch.
        .def("step", [](SimulatorHolder& h, int nthreads, double seconds, nb::handle tau) {
            Parts& P = *h.parts;
            std::unique_lock<std::mutex> lock(P.busy, std::try_to_lock);
            if (!lock) throw std::runtime_error("Simulator: stepped from two threads at once");
            const long ntau = static_cast<long>(P.tau.size()), nv = P.model->nv;
            if (!tau.is_none()) {
                if (const double* all = vector_of(tau, ntau)) {
                    std::copy(all, all + ntau, P.tau.data());
                } else if (const double* one = vector_of(tau, nv)) {
                    for (long k = 0; k < ntau; k += nv) std::copy(one, one + nv, P.tau.data() + k);
                } else {
                    return nb::make_tuple(0L, 0L, false, -2L);  // not taken: nothing stepped
                }
            }
            for (long k = 0; k < ntau; ++k)
                if (!std::isfinite(P.tau.data()[k])) return nb::make_tuple(0L, 0L, false, k);
            const int nt = P.callback ? 1 : std::max(1, nthreads);
            sim::StepOutcome o;
            {
                nb::gil_scoped_release unlocked;
                o = sim::step_all(*P.model, P.envs, P.settings, P.tau.data(), nt, seconds);
            }
            if (P.callback) P.callback->raise_if_failed();
            return nb::make_tuple(o.failed, o.skipped, o.expired, -1L);
        }, "nthreads"_a, "seconds"_a, "tau"_a.none() = nb::none())
        // Environments `which` take their state (t, q, v, h, phase) from the arrays again and are ready.
        .def("load", [](SimulatorHolder& h, Ints which) {
            Parts& P = *h.parts;
            std::unique_lock<std::mutex> lock(P.busy, std::try_to_lock);
            if (!lock) throw std::runtime_error("Simulator: loaded while it steps in another thread");
            const long N = static_cast<long>(P.envs.size());
            for (size_t k = 0; k < which.shape(0); ++k) require(which(k) >= 0 && which(k) < N, "which: out of range");
            for (size_t k = 0; k < which.shape(0); ++k) P.envs[which(k)].load();
        }, "which"_a);
}

}  // namespace bind
