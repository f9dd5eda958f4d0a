// A run's contact (core/contact/contact_model.hpp) as the Python object _core.ContactModel: made from a scene's
// arrays, each pair's bodies and material, and the arrays a run writes (the tracking, the kept contacts), all
// checked here before the core reads them; it evaluates one state (dynamics.contact_forces) and is what
// _core.run takes as a simulation's contact (bindings/simulation.cpp).
#include <string>

#include "arrays.hpp"
#include "contact/contact_model.hpp"
#include "numpy.hpp"

namespace bind {

using core::Model;
namespace ct = core::contact;

namespace {

template <class T, size_t N>
using CIn = nb::ndarray<const T, nb::ndim<N>, nb::c_contig, nb::device::cpu>;
template <class T, size_t N>
using COut = nb::ndarray<T, nb::ndim<N>, nb::c_contig, nb::device::cpu>;

// An array the core writes into: exactly that dtype and rank, C-contiguous, writable (never a converted copy,
// which would be written and lost).
template <class T, size_t N>
COut<T, N> writable(nb::handle x, const char* name) {
    COut<T, N> a;
    if (!nb::try_cast(x, a, false))
        throw nb::type_error((std::string(name) + ": expected a writable C-contiguous " + std::to_string(N) + "-d " +
                              (sizeof(T) == 8 && T(0.5) != 0 ? "float64" : "int64") + " array").c_str());
    return a;
}

}  // namespace

ct::Scene scene_of(const Model& model, nb::handle body, nb::handle kind, nb::handle size, nb::handle R, nb::handle p,
                   nb::handle radius, nb::handle pair_a, nb::handle pair_b);  // bindings/contact.cpp

// The arrays, kept alive with the model (the core holds pointers into them).
struct ContactHolder {
    nb::tuple scene;  // body, kind, size, R, p, radius, pair_a, pair_b: read in place (scene_of checked them)
    CIn<double, 2> mat;
    CIn<int64_t, 2> pair_body;
    COut<double, 1> track;
    COut<double, 3> out;
    COut<int64_t, 1> out_n;
    nb::object model_owner;
    std::unique_ptr<ct::ContactModel> model;
};

namespace {

// Each pair's bodies and material row checked against the scene (already checked by scene_of).
void require_pair_rows(const ContactHolder& h, const ct::Scene& S) {
    require(length(h.pair_body) == S.npairs && h.pair_body.shape(1) == 2, "pair_body: (npairs, 2)");
    require(length(h.mat) == S.npairs && h.mat.shape(1) == ct::NMAT, "mat: (npairs, 5)");
    for (long k = 0; k < S.npairs; ++k) {
        for (int s = 0; s < 2; ++s)
            require(h.pair_body(k, s) == S.body[s ? S.pair_b[k] : S.pair_a[k]],
                    "pair_body: the bodies of each pair's geometries");
        require(h.mat(k, ct::K_VS) > 0 && h.mat(k, ct::K_STIFF) >= 0, "mat: positive stiction velocity, stiffness");
    }
}

nb::object int_array(const int64_t* x, long n) {
    auto* copy = new int64_t[n > 0 ? n : 1];
    std::copy(x, x + n, copy);
    nb::capsule owner(copy, [](void* p) noexcept { delete[] static_cast<int64_t*>(p); });
    return nb::cast(nb::ndarray<nb::numpy, int64_t, nb::ndim<1>>(copy, {static_cast<size_t>(n)}, owner));
}

// The first n contacts of the last evaluation: (pair, point, normal, depth, detail) as new arrays.
nb::tuple contacts_of(const ct::ContactModel& c, int64_t n) {
    const ct::ContactBuffer& b = c.buffer();
    double *point, *normal, *depth, *detail;
    nb::object P = new_array(n, 3, &point), N = new_array(n, 3, &normal), D = new_array(n, &depth);
    nb::object E = new_array(n, ct::NDETAIL, &detail);
    for (int64_t k = 0; k < n; ++k) {
        for (int r = 0; r < 3; ++r) point[3 * k + r] = b.point[k][r], normal[3 * k + r] = b.normal[k][r];
        depth[k] = b.depth[k];
    }
    std::copy(c.detail(), c.detail() + n * ct::NDETAIL, detail);
    return nb::make_tuple(int_array(b.pair.data(), n), P, N, D, E);
}

// A hand-made contact list (K contacts, contact k of "pair" k: pair_body (K, 2), mat (K, 5), point (K, 3), normal
// (K, 3), depth (K,)), checked against the model, as a buffer.
ct::ContactBuffer contact_list(const Model& model, const CIn<int64_t, 2>& pair_body, const CIn<double, 2>& mat,
                               const CIn<double, 2>& point, const CIn<double, 2>& normal, const CIn<double, 1>& depth) {
    const long K = length(depth);
    require(length(pair_body) == K && pair_body.shape(1) == 2 && length(mat) == K && mat.shape(1) == ct::NMAT &&
                length(point) == K && point.shape(1) == 3 && length(normal) == K && normal.shape(1) == 3,
            "contacts: pair_body (K, 2), mat (K, 5), point and normal (K, 3), depth (K,)");
    ct::ContactBuffer buf(K);
    for (long k = 0; k < K; ++k) {
        for (int s = 0; s < 2; ++s)
            require(pair_body(k, s) >= -1 && pair_body(k, s) < model.nb, "pair_body: a body out of the model's range");
        require(mat(k, ct::K_VS) > 0, "mat: a positive stiction velocity");
        buf.pair[k] = k;
        buf.point[k] = {point(k, 0), point(k, 1), point(k, 2)};
        buf.normal[k] = {normal(k, 0), normal(k, 1), normal(k, 2)};
        buf.depth[k] = depth(k);
    }
    return buf;
}

const double* step(ContactHolder& h, const In<1>& delta) {
    require(length(delta) == h.model->model().nv, "delta: (nv,)");
    return delta.data();
}

}  // namespace

// The holder's core model (bindings/simulation.cpp's run takes it), checked to be made for `model`.
ct::ContactModel& contact_of(nb::handle x, const Model& model) {
    ContactHolder* h = nullptr;
    if (!nb::try_cast(x, h) || !h || !h->model) throw nb::type_error("contact: expected a _core.ContactModel or None");
    require(&h->model->model() == &model, "contact: made for another model");
    return *h->model;
}

namespace {

// The force law and its derivatives on hand-made contact lists (the tests' window onto core/contact/forces.hpp).
void expose_contact_lists(nb::module_& m) {
    using namespace nb::literals;
    // The force law on a hand-made contact list at (q, v): f_ext (nb, 6) = the body wrenches, tau += J_c^T f_c,
    // detail (K, 8) each contact's row; returns the contact power.
    m.def("contact_wrenches", [](const Model& model, In<1> q, In<1> v, CIn<int64_t, 2> pair_body, CIn<double, 2> mat,
                                 CIn<double, 2> point, CIn<double, 2> normal, CIn<double, 1> depth, nb::handle f_ext_,
                                 nb::handle tau_, nb::handle detail_) {
        require(length(q) == model.nq && length(v) == model.nv, "q, v: (nq,), (nv,)");
        const ct::ContactBuffer buf = contact_list(model, pair_body, mat, point, normal, depth);
        const long K = buf.capacity();
        const Output f_ext = output_of(f_ext_, 2), tau = output_of(tau_, 1), detail = output_of(detail_, 2);
        require(length(f_ext) == model.nb && f_ext.shape(1) == 6 && length(tau) == model.nv, "f_ext (nbodies, 6), tau (nv,)");
        require(length(detail) == K && detail.shape(1) == ct::NDETAIL, "detail: (K, 8)");
        std::vector<core::Transform> oMi(model.nb);
        std::vector<core::Force> fb(model.nb);
        return ct::contact_wrenches(model, core::thread_data(model), q.data(), v.data(), K, buf, pair_body.data(),
                                    mat.data(), oMi.data(), fb.data(), detail.data(), f_ext.data(), tau.data());
    }, "model"_a, "q"_a, "v"_a, "pair_body"_a, "mat"_a, "point"_a, "normal"_a, "depth"_a, "f_ext"_a, "tau"_a,
       "detail"_a);
    // dv = d tau_c/dv and dq = its stiffness part of d tau_c/dq (nv x nv) of a hand-made contact list at (q, v).
    m.def("contact_force_derivatives", [](const Model& model, In<1> q, In<1> v, CIn<int64_t, 2> pair_body,
                                          CIn<double, 2> mat, CIn<double, 2> point, CIn<double, 2> normal,
                                          CIn<double, 1> depth, nb::handle dq_, nb::handle dv_) {
        require(length(q) == model.nq && length(v) == model.nv, "q, v: (nq,), (nv,)");
        const ct::ContactBuffer buf = contact_list(model, pair_body, mat, point, normal, depth);
        const Output dq = output_of(dq_, 2), dv = output_of(dv_, 2);
        for (const Output* a : {&dq, &dv}) require(length(*a) == model.nv && a->shape(1) == model.nv, "dq, dv: (nv, nv)");
        core::Data& data = core::thread_data(model);
        std::vector<core::Transform> oMi(model.nb);
        core::forward_pass(model, data, q.data(), nullptr, false);
        ct::world_poses(model, data.X.data(), oMi.data());
        ct::ForceDerivativesWork w(model.nv);
        ct::contact_force_derivatives(model, buf.capacity(), buf, pair_body.data(), mat.data(), oMi.data(), v.data(),
                                      dq.data(), dv.data(), w);
    }, "model"_a, "q"_a, "v"_a, "pair_body"_a, "mat"_a, "point"_a, "normal"_a, "depth"_a, "dq"_a, "dv"_a);
}

}  // namespace

void expose_contact_model(nb::module_& m) {
    using namespace nb::literals;
    expose_contact_lists(m);
    nb::class_<ContactHolder>(m, "ContactModel", "A run's contact (core/contact/contact_model.hpp).")
        .def("__init__", [](ContactHolder* self, nb::handle model_, nb::handle body, nb::handle kind, nb::handle size,
                            nb::handle R, nb::handle p, nb::handle radius, nb::handle pair_a, nb::handle pair_b,
                            CIn<int64_t, 2> pair_body, CIn<double, 2> mat, long K, nb::handle track, nb::handle out,
                            nb::handle out_n, bool exact) {
            const Model* pm = nullptr;
            if (!nb::try_cast(model_, pm) || !pm) throw nb::type_error("model: expected the model's core");
            const Model& model = *pm;
            // checked and made before self is: an __init__ that throws leaves self unconstructed (never destroyed)
            ContactHolder h{nb::make_tuple(body, kind, size, R, p, radius, pair_a, pair_b), mat, pair_body,
                            writable<double, 1>(track, "track"), writable<double, 3>(out, "out"),
                            writable<int64_t, 1>(out_n, "out_n"), nb::borrow(model_), nullptr};
            ct::ContactArrays a;
            a.scene = scene_of(model, body, kind, size, R, p, radius, pair_a, pair_b);
            require_pair_rows(h, a.scene);
            require(K >= 0 && K <= 8 * a.scene.npairs, "K: the scene's max_contacts, at most 8 per pair");
            require(length(h.track) == 3, "track: (3,)");
            const long T = length(h.out);
            require(length(h.out_n) == T && (T == 0 || (h.out.shape(1) == size_t(K) && h.out.shape(2) == ct::NOUT)),
                    "out: (T, K, 15) and out_n (T,)");
            a.pair_body = h.pair_body.data(), a.mat = h.mat.data(), a.K = K, a.track = h.track.data();
            a.out = T ? h.out.data() : nullptr, a.out_n = h.out_n.data(), a.T = T;
            h.model = std::make_unique<ct::ContactModel>(model, a, exact);  // (the arrays' data does not move)
            new (self) ContactHolder(std::move(h));
        }, "model"_a, "body"_a, "kind"_a, "size"_a, "R"_a, "p"_a, "radius"_a, "pair_a"_a, "pair_b"_a, "pair_body"_a,
           "mat"_a, "K"_a, "track"_a, "out"_a, "out_n"_a, "exact"_a)
        // One state: f_ext (nb, 6) = the body wrenches, tau += J_c^T f_c; returns (power, pair, point, normal, depth,
        // detail) of its contacts.
        .def("evaluate", [](ContactHolder& h, In<1> q, In<1> v, nb::handle f_ext_, nb::handle tau_) {
            const Model& model = h.model->model();
            require(length(q) == model.nq && length(v) == model.nv, "q, v: (nq,), (nv,)");
            const Output f_ext = output_of(f_ext_, 2), tau = output_of(tau_, 1);
            require(length(f_ext) == model.nb && f_ext.shape(1) == 6 && length(tau) == model.nv,
                    "f_ext (nbodies, 6), tau (nv,)");
            int64_t n;
            const double power = h.model->evaluate(q.data(), v.data(), tau.data(), f_ext.data(), n);
            return nb::make_tuple(power) + contacts_of(*h.model, n);
        }, "q"_a, "v"_a, "f_ext"_a, "tau"_a)
        // dv = d tau_c/dv, dq = its stiffness part of d tau_c/dq at (q, v) (nv x nv): the simulation Jacobian's
        // contact terms, for the tests.
        .def("force_derivatives", [](ContactHolder& h, In<1> q, In<1> v, nb::handle dq_, nb::handle dv_) {
            const Model& model = h.model->model();
            require(length(q) == model.nq && length(v) == model.nv, "q, v: (nq,), (nv,)");
            const Output dq = output_of(dq_, 2), dv = output_of(dv_, 2);
            for (const Output* a : {&dq, &dv})
                require(length(*a) == model.nv && a->shape(1) == model.nv, "dq, dv: (nv, nv)");
            h.model->jacobian(model, q.data(), v.data(), dq.data(), dv.data());
        }, "q"_a, "v"_a, "dq"_a, "dv"_a)
        // The clearance (core/contact/clearance.hpp), for the tests: measured at q, then its bound along a step's
        // chart coordinate delta; `clearance` is (g, D0, referenced).
        .def("set_reference", [](ContactHolder& h, In<1> q) {
            require(length(q) == h.model->model().nq, "q: (nq,)");
            h.model->measure(q.data());
        }, "q"_a)
        .def("moved", [](ContactHolder& h, In<1> delta) { return h.model->clearance().moved(step(h, delta)); })
        .def("apart", [](ContactHolder& h, In<1> delta) { return h.model->clearance().apart(step(h, delta)); })
        .def("advance", [](ContactHolder& h, In<1> delta) { return h.model->clearance().advance(step(h, delta)); })
        .def_prop_ro("clearance", [](ContactHolder& h) {
            const ct::Clearance& c = h.model->clearance();
            return nb::make_tuple(c.separation(), c.bound(), c.referenced());
        });
}

}  // namespace bind
