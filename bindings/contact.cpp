// The narrow phase (core/contact/narrow_phase.hpp) at one configuration: the contacts of a scene and the world
// poses of its geometry.  The scene's arrays come from dynamics/contact/scene.py's Scene, read in place (NumPy's
// C API, numpy.hpp) after every one is checked here -- dtype, layout, shapes against each other, every index in
// range -- before any C++ reads it: a scene from a pickle, a test or another model never reaches the core with an
// index it would follow out of its arrays.
#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "checks.hpp"
#include "contact/narrow_phase.hpp"
#include "kinematics.hpp"
#include "numpy.hpp"

namespace bind {

using core::Model;
using core::contact::Scene;

// The most contacts one pair writes (box-plane's 8 vertices, box-box's manifold, clipped to 8): a larger buffer is
// never filled, so it is not allocated either.  A K beyond MAX_K is a mistake, not a scene.
constexpr long MAX_PER_PAIR = 8;
constexpr long MAX_K = 1L << 31;

static std::string got(long n) { return ", got " + std::to_string(n); }

// body (ng,) int64 in [-1, nb), R (ng, 3, 3) and p (ng, 3) float64: what a geometry's world pose needs.
static void placement_arrays(const Model& model, nb::handle body, nb::handle R, nb::handle p, Scene& S) {
    const Input b = input_of(body, 'q', 1, "body"), r = input_of(R, 'd', 3, "R"), x = input_of(p, 'd', 2, "p");
    S.ng = b.shape(0);
    require(r.shape(0) == S.ng && r.shape(1) == 3 && r.shape(2) == 3,
            "R: expected shape (" + std::to_string(S.ng) + ", 3, 3), one rotation per geometry of body");
    require(x.shape(0) == S.ng && x.shape(1) == 3,
            "p: expected shape (" + std::to_string(S.ng) + ", 3), one position per geometry of body");
    for (long g = 0; g < S.ng; ++g)
        require(b.ints()[g] >= -1 && b.ints()[g] < model.nb,
                "body: expected body indices in [-1, " + std::to_string(model.nb) + ") (the model's bodies or -1, "
                "the world), got " + std::to_string(b.ints()[g]) + " at " + std::to_string(g));
    S.body = b.ints(), S.R = r.doubles(), S.p = x.doubles();
}

// kind (ng,) int64 in [0, 5], size (ng, 3) and radius (ng,) float64.
static void shape_arrays(nb::handle kind, nb::handle size, nb::handle radius, Scene& S) {
    const Input k = input_of(kind, 'q', 1, "kind"), s = input_of(size, 'd', 2, "size");
    const Input r = input_of(radius, 'd', 1, "radius");
    const std::string ng = std::to_string(S.ng);
    require(k.shape(0) == S.ng, "kind: expected " + ng + " kinds (one per geometry)" + got(k.shape(0)));
    require(s.shape(0) == S.ng && s.shape(1) == 3, "size: expected shape (" + ng + ", 3)");
    require(r.shape(0) == S.ng, "radius: expected " + ng + " radii (one per geometry)" + got(r.shape(0)));
    for (long g = 0; g < S.ng; ++g)
        require(k.ints()[g] >= core::contact::SPHERE && k.ints()[g] <= core::contact::PLANE,
                "kind: expected kinds in [0, 5], got " + std::to_string(k.ints()[g]) + " at " + std::to_string(g));
    S.kind = k.ints(), S.size = s.doubles(), S.radius = r.doubles();
}

// pair_a, pair_b (npairs,) int64: geometry indices in [0, ng), each pair ordered by kind (the pair functions'
// table reads the pair's lower kind first).
static void pair_arrays(nb::handle pair_a, nb::handle pair_b, Scene& S) {
    const Input a = input_of(pair_a, 'q', 1, "pair_a"), b = input_of(pair_b, 'q', 1, "pair_b");
    S.npairs = a.shape(0);
    require(b.shape(0) == S.npairs, "pair_b: expected " + std::to_string(S.npairs) + " indices (as many as pair_a)" +
                                        got(b.shape(0)));
    for (long k = 0; k < S.npairs; ++k) {
        const int64_t ga = a.ints()[k], gb = b.ints()[k];
        const std::string at = " at " + std::to_string(k);
        require(ga >= 0 && ga < S.ng, "pair_a: expected geometry indices in [0, " + std::to_string(S.ng) + ")" + at);
        require(gb >= 0 && gb < S.ng, "pair_b: expected geometry indices in [0, " + std::to_string(S.ng) + ")" + at);
        require(S.kind[ga] <= S.kind[gb], "pair_a, pair_b: expected kind[a] <= kind[b]" + at);
    }
    S.pair_a = a.ints(), S.pair_b = b.ints();
}

// Every body's world pose at q (a finite configuration of the model) into the thread's data.oMi.
static const core::Transform* world_poses(const Model& model, nb::handle q) {
    const Input x = input_of(q, 'd', 1, "q");
    require(x.shape(0) == model.nq, "q: expected " + std::to_string(model.nq) + " coordinates" + got(x.shape(0)));
    require(core::configuration_ok(model, x.doubles()), "q: expected a finite configuration (non-zero quaternions)");
    core::Data& data = core::thread_data(model);
    for (int i = 0; i < model.nb; ++i) core::world_pose(model, data, i, x.doubles());
    return data.oMi.data();
}

// The scene's arrays, every one checked (also bindings/contact_model.cpp's, for a run's contact).
Scene scene_of(const Model& model, nb::handle body, nb::handle kind, nb::handle size, nb::handle R, nb::handle p,
               nb::handle radius, nb::handle pair_a, nb::handle pair_b) {
    Scene S;
    placement_arrays(model, body, R, p, S);
    shape_arrays(kind, size, radius, S);
    pair_arrays(pair_a, pair_b, S);
    return S;
}

// The buffer of K contacts (the scene's max_contacts, or more) collide writes at most.
static long capacity(const Scene& S, long K) {
    require(K >= 0 && K < MAX_K, "K: expected a buffer of 0 to 2^31 contacts (the scene's max_contacts)" + got(K));
    return std::min(K, MAX_PER_PAIR * S.npairs);
}

// (pair (n,) int64, point (n, 3), normal (n, 3), depth (n,)): the first n contacts of the buffer, copied.
static nb::tuple contacts(const core::contact::ContactBuffer& out, long n) {
    int64_t* pair;
    double *point, *normal, *depth;
    nb::object P = new_int_array(n, &pair), X = new_array(n, 3, &point), N = new_array(n, 3, &normal);
    nb::object D = new_array(n, &depth);
    for (long c = 0; c < n; ++c) {
        pair[c] = out.pair[c], depth[c] = out.depth[c];
        for (int r = 0; r < 3; ++r) point[3 * c + r] = out.point[c][r], normal[3 * c + r] = out.normal[c][r];
    }
    return nb::make_tuple(P, X, N, D);
}

void expose_contact(nb::module_& m) {
    using namespace nb::literals;

    m.def("find_contacts", [](const Model& model, nb::handle body, nb::handle kind, nb::handle size, nb::handle R,
                              nb::handle p, nb::handle radius, nb::handle pair_a, nb::handle pair_b, nb::handle q,
                              long K) {
        const Scene S = scene_of(model, body, kind, size, R, p, radius, pair_a, pair_b);
        const long room = capacity(S, K);
        const core::Transform* oMi = world_poses(model, q);
        core::contact::ContactBuffer out(room);
        const long n = core::contact::collide(S, oMi, out);
        return contacts(out, n);
    }, "model"_a, "body"_a, "kind"_a, "size"_a, "R"_a, "p"_a, "radius"_a, "pair_a"_a, "pair_b"_a, "q"_a, "K"_a);

    // find_contacts at given world poses of the bodies ((nbodies, 4, 4), the last rows ignored) instead of a
    // configuration: the pair functions on poses a configuration cannot reach exactly (the tests' hand-made cases)
    m.def("collide_at", [](const Model& model, nb::handle body, nb::handle kind, nb::handle size, nb::handle R,
                           nb::handle p, nb::handle radius, nb::handle pair_a, nb::handle pair_b, nb::handle poses,
                           long K) {
        const Scene S = scene_of(model, body, kind, size, R, p, radius, pair_a, pair_b);
        const long room = capacity(S, K);
        const Input T = input_of(poses, 'd', 3, "poses");
        require(T.shape(0) == model.nb && T.shape(1) == 4 && T.shape(2) == 4,
                "poses: expected (" + std::to_string(model.nb) + ", 4, 4)" + got(T.shape(0)));
        std::vector<core::Transform> oMi(model.nb);
        for (int i = 0; i < model.nb; ++i) {
            const double* X = T.doubles() + 16 * i;
            for (int r = 0; r < 3; ++r) {
                for (int c = 0; c < 3; ++c) oMi[i].R[3 * r + c] = X[4 * r + c];
            }
            oMi[i].p = {X[3], X[7], X[11]};
        }
        core::contact::ContactBuffer out(room);
        const long n = core::contact::collide(S, oMi.data(), out);
        return contacts(out, n);
    }, "model"_a, "body"_a, "kind"_a, "size"_a, "R"_a, "p"_a, "radius"_a, "pair_a"_a, "pair_b"_a, "poses"_a, "K"_a);

    m.def("scene_poses", [](const Model& model, nb::handle body, nb::handle R, nb::handle p, nb::handle q) {
        Scene S;
        placement_arrays(model, body, R, p, S);
        const core::Transform* oMi = world_poses(model, q);
        double* T;
        nb::object out = new_array(S.ng, 4, 4, &T);
        for (long g = 0; g < S.ng; ++g) core::store_pose(core::contact::geometry_pose(S, g, oMi), T + 16 * g);
        return out;
    }, "model"_a, "body"_a, "R"_a, "p"_a, "q"_a);

    // benchmarks/narrow_phase.py: seconds per collide of the scene at q (the world poses computed once), the
    // mean of `repeats` calls in a tight loop, and the contacts of the last
    m.def("collide_bench", [](const Model& model, nb::handle body, nb::handle kind, nb::handle size, nb::handle R,
                              nb::handle p, nb::handle radius, nb::handle pair_a, nb::handle pair_b, nb::handle q,
                              long K, long repeats) {
        const Scene S = scene_of(model, body, kind, size, R, p, radius, pair_a, pair_b);
        const long room = capacity(S, K);
        require(repeats >= 1 && repeats <= 100000000, "repeats: expected 1 to 10^8" + got(repeats));
        const core::Transform* oMi = world_poses(model, q);
        core::contact::ContactBuffer out(room);
        long n = 0;
        const auto t0 = std::chrono::steady_clock::now();
        for (long r = 0; r < repeats; ++r) n = core::contact::collide(S, oMi, out);
        const std::chrono::duration<double> dt = std::chrono::steady_clock::now() - t0;
        return nb::make_tuple(dt.count() / static_cast<double>(repeats), n);
    }, "model"_a, "body"_a, "kind"_a, "size"_a, "R"_a, "p"_a, "radius"_a, "pair_a"_a, "pair_b"_a, "q"_a, "K"_a,
       "repeats"_a);
}

}  // namespace bind
