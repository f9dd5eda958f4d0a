// Frames (placements, motions, Jacobians and their time variation), the centre of mass, the task-space
// inertia's J M^-1 J^T and inverse kinematics: single calls (exact float64 arrays, checked here; None sends the
// caller to its general path) and batches (shapes checked again; the GIL released around the threads).
#include <algorithm>
#include <functional>

#include "arrays.hpp"
#include "checks.hpp"
#include "com.hpp"
#include "inverse_kinematics.hpp"
#include "jacobians.hpp"
#include "kinematics.hpp"
#include "numpy.hpp"
#include "task_space.hpp"

namespace bind {

using core::Data;
using core::Model;

static void require_frame(const Model& model, long f) {
    require(f >= 0 && f < model.nf, "frame: index out of range");
}
static void require_reference(long ref) { require(ref >= 0 && ref <= 2, "reference: unknown code"); }

static nb::tuple run(const Model& model, long B, int nthreads, double seconds,
                     const std::function<int(long, Data&)>& kernel) {
    core::BatchStatus s;
    {
        nb::gil_scoped_release unlocked;
        s = core::run_batch(model, B, nthreads, seconds, kernel);
    }
    return status(s);
}

void expose_kinematics(nb::module_& m) {
    using namespace nb::literals;

    m.def("placements", [](const Model& model, nb::handle q) -> nb::object {
        const double* pq = vector_of(q, model.nq);
        if (!pq || !core::configuration_ok(model, pq)) return nb::none();
        double* out;
        nb::object T = new_array(model.nf, 4, 4, &out);
        core::placements(model, core::thread_data(model), pq, out);
        return T;
    }, "model"_a, "q"_a.none());

    m.def("frame_jacobian", [](const Model& model, nb::handle q, long f, long ref) -> nb::object {
        const double* pq = vector_of(q, model.nq);
        if (!pq || f < 0 || f >= model.nf || ref < 0 || ref > 2 || !core::configuration_ok(model, pq))
            return nb::none();
        double* J;
        nb::object out = new_array(6, model.nv, &J);
        std::fill(J, J + 6 * model.nv, 0.0);
        core::frame_jacobian(model, core::thread_data(model), pq, static_cast<int>(f), static_cast<int>(ref), {}, J);
        return out;
    }, "model"_a, "q"_a.none(), "f"_a, "ref"_a);

    m.def("center_of_mass", [](const Model& model, nb::handle q, bool jacobian) -> nb::object {
        const double* pq = vector_of(q, model.nq);
        if (!pq || !core::configuration_ok(model, pq)) return nb::none();
        double* c;
        nb::object out = jacobian ? new_array(3, model.nv, &c) : new_array(3, &c);
        core::center_of_mass(model, core::thread_data(model), pq, pq, jacobian ? core::COM_JACOBIAN : core::COM, c);
        return out;
    }, "model"_a, "q"_a.none(), "jacobian"_a);

    m.def("placements_batch", [](const Model& model, In<2> Q, nb::handle out_, int nthreads, double seconds) {
        const Output out = output_of(out_, 4);
        const long B = length(out);
        require_rows(Q, B, model.nq, "q");
        require((out.shape(1)) == model.nf && out.shape(2) == 4 && out.shape(3) == 4, "out: shape");
        return run(model, B, nthreads, seconds, [&](long b, Data& d) {
            core::placements(model, d, row(Q, b), out.data() + b * model.nf * 16);
            return -1;
        });
    });

    m.def("frame_placement_batch", [](const Model& model, In<2> Q, long f, nb::handle out_, int nthreads, double seconds) {
        const Output out = output_of(out_, 3);
        const long B = length(out);
        require_rows(Q, B, model.nq, "q"), require_frame(model, f);
        require(out.shape(1) == 4 && out.shape(2) == 4, "out: shape");
        return run(model, B, nthreads, seconds, [&](long b, Data& d) {
            core::frame_placement(model, d, row(Q, b), static_cast<int>(f), out.data() + b * 16);
            return -1;
        });
    });

    m.def("frame_motion_batch", [](const Model& model, In<2> Q, In<2> V, In<2> A, long f, long ref, int what,
                                   bool classical, nb::handle out_, int nthreads, double seconds) {
        const Output out = output_of(out_, 2);
        const long B = length(out);
        require_rows(Q, B, model.nq, "q"), require_rows(V, B, model.nv, "v"), require_rows(A, B, model.nv, "a");
        require_frame(model, f), require_reference(ref), require(what >= 0 && what <= 2, "what: unknown code");
        require(out.shape(1) == 6, "out: shape");
        return run(model, B, nthreads, seconds, [&](long b, Data& d) {
            core::frame_motion(model, d, row(Q, b), row(V, b), row(A, b), static_cast<int>(f), static_cast<int>(ref),
                               what, classical, out.data() + b * 6);
            return -1;
        });
    });

    m.def("frame_jacobian_batch", [](const Model& model, In<2> Q, long f, long ref, In<1> point, nb::handle out_,
                                     int nthreads, double seconds) {
        const Output out = output_of(out_, 3);
        const long B = length(out), nv = model.nv;
        require_rows(Q, B, model.nq, "q"), require_frame(model, f), require_reference(ref);
        require(out.shape(1) == 6 && (out.shape(2)) == nv, "out: shape");
        const core::Vec3 pt = vec3(point, "point");
        return run(model, B, nthreads, seconds, [&](long b, Data& d) {
            double* J = out.data() + b * 6 * nv;
            std::fill(J, J + 6 * nv, 0.0);
            core::frame_jacobian(model, d, row(Q, b), static_cast<int>(f), static_cast<int>(ref), pt, J);
            return -1;
        });
    });

    m.def("frame_jacobian_time_variation", [](const Model& model, In<1> q, In<1> v, long f, long ref, nb::handle out_) {
        const Output out = output_of(out_, 2);
        require(length(q) == model.nq && length(v) == model.nv, "q, v: lengths");
        require_frame(model, f), require_reference(ref);
        require(out.shape(0) == 6 && (out.shape(1)) == model.nv, "out: shape");
        core::frame_jacobian_time_variation(model, core::thread_data(model), q.data(), v.data(), static_cast<int>(f),
                                            static_cast<int>(ref), out.data());
    });

    m.def("center_of_mass_batch", [](const Model& model, In<2> Q, In<2> V, int what, nb::handle out_, int nthreads,
                                     double seconds) {
        const Output out = output_of(out_, 3);
        const long B = length(out);
        require(what >= 0 && what <= 2, "what: unknown code");
        const long cols = what == core::COM_JACOBIAN ? model.nv : 1;
        require_rows(Q, B, model.nq, "q"), require(out.shape(1) == 3 && (out.shape(2)) == cols, "out: shape");
        if (what == core::COM_VELOCITY) require_rows(V, B, model.nv, "v");
        return run(model, B, nthreads, seconds, [&](long b, Data& d) {
            core::center_of_mass(model, d, row(Q, b), what == core::COM_VELOCITY ? row(V, b) : nullptr, what,
                                 out.data() + b * 3 * cols);
            return -1;
        });
    });

    m.def("jminvjt_batch", [](const Model& model, In<2> Q, long f, long ref, Ints rows, nb::handle out_, int nthreads,
                              double seconds) {
        const Output out = output_of(out_, 3);
        const long B = length(out), r = length(rows);
        require_rows(Q, B, model.nq, "q"), require_frame(model, f), require_reference(ref);
        require(r >= 1 && r <= 6, "rows: 1 to 6 rows");
        for (long k = 0; k < r; ++k) require(rows(k) >= 0 && rows(k) < 6, "rows: indices in [0, 6)");
        require((out.shape(1)) == r && (out.shape(2)) == r, "out: shape");
        int pr[6];
        for (long k = 0; k < r; ++k) pr[k] = static_cast<int>(rows(k));
        return run(model, B, nthreads, seconds, [&](long b, Data& d) {
            return core::jminvjt(model, d, row(Q, b), static_cast<int>(f), static_cast<int>(ref), pr,
                                 static_cast<int>(r), out.data() + b * r * r);
        });
    });

    // out (B, nq + 5): q, then status, iterations, residual, position error, orientation error
    m.def("inverse_kinematics_batch", [](const Model& model, In<2> Q0, In<3> T, long f, int r, double tol,
                                         int max_iter, double damping, bool limits, nb::handle out_, int nthreads,
                                         double seconds) {
        const Output out = output_of(out_, 2);
        const long B = length(out), nq = model.nq;
        require_rows(Q0, B, nq, "q0"), require_frame(model, f), require(r == 3 || r == 6, "rows: 3 or 6");
        require((static_cast<long>(T.shape(0)) == B || T.shape(0) == 1) && T.shape(1) == 4 && T.shape(2) == 4,
                "target: shape");
        require((out.shape(1)) == nq + 5 && max_iter >= 0, "out: shape");
        return run(model, B, nthreads, seconds, [&](long b, Data& d) {
            const double* t = T.data() + (T.shape(0) == 1 ? 0 : b) * 16;
            const core::Transform target = {{{t[0], t[1], t[2], t[4], t[5], t[6], t[8], t[9], t[10]}}, {t[3], t[7], t[11]}};
            double* o = out.data() + b * (nq + 5);
            core::IkResult res = core::inverse_kinematics(model, d, row(Q0, b), target, static_cast<int>(f), r, tol,
                                                          max_iter, damping, limits, o);
            o[nq] = res.status, o[nq + 1] = res.iterations, o[nq + 2] = res.residual;
            o[nq + 3] = res.position_error, o[nq + 4] = res.orientation_error;
            return -1;
        });
    });
}

}  // namespace bind
