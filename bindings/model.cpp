// The core's Model, built from the Python model's arrays (dynamics/model.py) and checked (core/model.cpp).
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include "arrays.hpp"
#include "checks.hpp"
#include "joints.hpp"

namespace bind {

using Array = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;

static const double* values(const Array& a, size_t n, const char* name) {
    require(a.size() == n, std::string(name) + ": expected " + std::to_string(n) + " numbers, got " + std::to_string(a.size()));
    return a.data();
}

static std::vector<int> ints(const Ints& a, size_t n, const char* name) {
    require(a.shape(0) == n, std::string(name) + ": expected " + std::to_string(n) + " integers");
    std::vector<int> out(n);
    for (size_t k = 0; k < n; ++k) {
        require(a(k) >= -1 && a(k) < (1 << 30), std::string(name) + ": index out of range");
        out[k] = static_cast<int>(a(k));
    }
    return out;
}

static std::vector<core::Mat3> mat3s(const Array& a, size_t n, const char* name) {
    const double* x = values(a, 9 * n, name);
    std::vector<core::Mat3> out(n);
    for (size_t i = 0; i < n; ++i)
        for (int k = 0; k < 9; ++k) out[i][k] = x[9 * i + k];
    return out;
}

static std::vector<core::Vec3> vec3s(const Array& a, size_t n, const char* name) {
    const double* x = values(a, 3 * n, name);
    std::vector<core::Vec3> out(n);
    for (size_t i = 0; i < n; ++i) out[i] = {x[3 * i], x[3 * i + 1], x[3 * i + 2]};
    return out;
}

static core::Model make_model(const Ints& parents, const Ints& jtype, const Ints& q_idx, const Ints& v_idx,
                              const Ints& nv_j, const Array& Xrot, const Array& Xpos, const Array& axis,
                              const Array& S, const Array& mass, const Array& h, const Array& Io, const Array& XK,
                              const Array& XKK, const Array& gravity, const Array& lower, const Array& upper,
                              const Ints& frame_body, const Ints& frame_kind, const Array& frame_R,
                              const Array& frame_p) {
    core::Model m;
    const size_t nb = parents.shape(0), nf = frame_body.shape(0);
    require(S.ndim() == 2 && S.shape(1) == 6, "S: expected (nv, 6)");
    const size_t nv = S.shape(0);
    m.nb = static_cast<int>(nb), m.nv = static_cast<int>(nv), m.nf = static_cast<int>(nf);
    m.parents = ints(parents, nb, "parents"), m.jtype = ints(jtype, nb, "jtype");
    m.q_idx = ints(q_idx, nb, "q_idx"), m.v_idx = ints(v_idx, nb, "v_idx"), m.nv_j = ints(nv_j, nb, "nv_j");
    m.Xrot = mat3s(Xrot, nb, "Xrot"), m.XK = mat3s(XK, nb, "XK"), m.XKK = mat3s(XKK, nb, "XKK");
    m.Xpos = vec3s(Xpos, nb, "Xpos"), m.axis = vec3s(axis, nb, "axis");
    const double* s = values(S, 6 * nv, "S");
    for (size_t k = 0; k < nv; ++k) m.S.push_back(core::motion_from(s + 6 * k));
    const double* ms = values(mass, nb, "mass");
    std::vector<core::Vec3> hs = vec3s(h, nb, "h");
    std::vector<core::Mat3> Ios = mat3s(Io, nb, "Io");
    for (size_t i = 0; i < nb; ++i) m.I.push_back({ms[i], hs[i], Ios[i]});
    const double* g = values(gravity, 3, "gravity");
    m.gravity = {g[0], g[1], g[2]};
    m.lower.assign(values(lower, nv, "lower"), values(lower, nv, "lower") + nv);
    m.upper.assign(values(upper, nv, "upper"), values(upper, nv, "upper") + nv);
    m.frame_body = ints(frame_body, nf, "frame body"), m.frame_kind = ints(frame_kind, nf, "frame kind");
    m.frame_R = mat3s(frame_R, nf, "frame R"), m.frame_p = vec3s(frame_p, nf, "frame p");
    m.nq = 0;
    for (size_t i = 0; i < nb; ++i) {
        require(m.jtype[i] >= 0 && m.jtype[i] < core::JOINT_TYPES, "jtype: unknown joint type");
        m.nq += core::joint_nq(m.jtype[i]);
    }
    core::check(m);
    return m;
}

void expose_model(nb::module_& mod) {
    nb::class_<core::Model>(mod, "Model", "The core's immutable model (core/model.hpp), built from the Python model's arrays.")
        .def("__init__",
             [](core::Model* self, const Ints& parents, const Ints& jtype, const Ints& q_idx, const Ints& v_idx,
                const Ints& nv_j, const Array& Xrot, const Array& Xpos, const Array& axis, const Array& S,
                const Array& mass, const Array& h, const Array& Io, const Array& XK, const Array& XKK,
                const Array& gravity, const Array& lower, const Array& upper, const Ints& frame_body,
                const Ints& frame_kind, const Array& frame_R, const Array& frame_p) {
                 new (self) core::Model(make_model(parents, jtype, q_idx, v_idx, nv_j, Xrot, Xpos, axis, S, mass, h,
                                                   Io, XK, XKK, gravity, lower, upper, frame_body, frame_kind,
                                                   frame_R, frame_p));
             },
             nb::arg("parents"), nb::arg("jtype"), nb::arg("q_idx"), nb::arg("v_idx"), nb::arg("nv_j"),
             nb::arg("Xrot"), nb::arg("Xpos"), nb::arg("axis"), nb::arg("S"), nb::arg("mass"), nb::arg("h"),
             nb::arg("Io"), nb::arg("XK"), nb::arg("XKK"), nb::arg("gravity"), nb::arg("lower"), nb::arg("upper"),
             nb::arg("frame_body"), nb::arg("frame_kind"), nb::arg("frame_R"), nb::arg("frame_p"))
        .def_ro("nb", &core::Model::nb)
        .def_ro("nq", &core::Model::nq)
        .def_ro("nv", &core::Model::nv)
        .def_ro("nf", &core::Model::nf);

    // every joint type's facts the Python side reads (dynamics/joints.py's KINDS): code -> (nq, nv, neutral q)
    mod.def("joint_types", [] {
        nb::dict out;
        for (int t = 0; t < core::JOINT_TYPES; ++t) {
            std::vector<double> q0(core::joint_nq(t));
            core::joint_neutral(t, q0.data());
            out[nb::int_(t)] = nb::make_tuple(core::joint_nq(t), core::joint_nv(t), nb::tuple(nb::cast(q0)));
        }
        return out;
    });

    // the general path's input checks (dynamics/checks.py): the first row of X holding a nan or an inf, or -1
    mod.def("first_nonfinite", [](const In<2>& X) -> long {
        return core::first_nonfinite_row(X.data(), static_cast<long>(X.shape(0)), static_cast<long>(X.shape(1)));
    }, nb::arg("X"));

    // the row r of blocks (start, size in q) of the first zero unit block (a quaternion, a planar joint's
    // (cos, sin)) in any row of Q, or -1
    mod.def("first_zero_unit", [](const In<2>& Q, const nb::ndarray<const int64_t, nb::ndim<2>, nb::c_contig,
                                                                      nb::device::cpu>& blocks) -> long {
        const long B = static_cast<long>(Q.shape(0)), n = static_cast<long>(Q.shape(1));
        const long R = static_cast<long>(blocks.shape(0));
        require(blocks.shape(1) == 2, "blocks: expected (R, 2) rows (start, size)");
        for (long r = 0; r < R; ++r)
            require(blocks(r, 0) >= 0 && blocks(r, 1) >= 0 && blocks(r, 0) + blocks(r, 1) <= n,
                    "blocks: a block outside the configuration");
        for (long b = 0; b < B; ++b)
            for (long r = 0; r < R; ++r) {
                const double* x = Q.data() + b * n + blocks(r, 0);
                double s = 0.0;
                for (long j = 0; j < blocks(r, 1); ++j) s += x[j] * x[j];
                if (s < core::ZERO_QUATERNION_SQ) return r;
            }
        return -1;
    }, nb::arg("Q"), nb::arg("blocks"));
}

}  // namespace bind
