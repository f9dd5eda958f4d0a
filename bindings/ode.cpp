// The solvers on plain ODEs, and their linear algebra, for the tests (tests/test_simulate_solvers.py): a Python
// f(t, z) -> dz as the problem (called with the GIL taken), so that each method is checked against closed forms
// and scipy apart from any robot.
#include <nanobind/stl/complex.h>
#include <nanobind/stl/string.h>

#include <complex>
#include <cstring>
#include <memory>

#include "numpy.hpp"
#include "run_args.hpp"
#include "simulation/linalg.hpp"
#include "simulation/second_order.hpp"
#include "simulation/solver.hpp"

namespace bind {

namespace {

// z' = f(t, z); euler's configuration step moves the first half of z by the second (a second-order system);
// samples into out_t, out_z.  A failed f stops the run (raised after it).
class PyODE : public core::sim::Problem {
public:
    PyODE(nb::object f, int n, double* out_t, double* out_z) : f_(std::move(f)), n_(n), out_t_(out_t), out_z_(out_z) {}
    void rhs(double t, const double* z, double* dz) override {
        if (error_) {
            std::fill(dz, dz + n_, std::nan(""));
            return;
        }
        nb::gil_scoped_acquire gil;
        try {
            double* pz;
            nb::object Z = new_array(n_, &pz);
            std::copy(z, z + n_, pz);
            const double* r = vector_of(f_(t, Z), n_);
            require(r != nullptr, "f: must return a float64 array of shape (n,)");
            std::copy(r, r + n_, dz);
        } catch (nb::python_error& e) {
            error_ = std::make_unique<nb::python_error>(std::move(e));
            std::fill(dz, dz + n_, std::nan(""));
        }
    }
    void rebase(double, double*, double*, double* mag) override { std::fill(mag, mag + n_, 0.0); }
    void euler_config(double* z, double h) override {
        for (int i = 0; i < n_ / 2; ++i) z[i] += h * z[n_ / 2 + i];
    }
    void emit(int64_t j, double t, const double* z) override {
        out_t_[j] = t;
        std::copy(z, z + n_, out_z_ + j * n_);
    }
    bool aborted() const override { return error_ != nullptr; }
    void raise_if_failed() {
        if (error_) {
            error_->restore();
            throw nb::python_error();
        }
    }

private:
    nb::object f_;
    int n_;
    double *out_t_, *out_z_;
    std::unique_ptr<nb::python_error> error_;
};

template <class T>
using Square = nb::ndarray<T, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
template <class T>
using Vector = nb::ndarray<T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

template <class T>
int square(const Square<T>& A, std::initializer_list<size_t> lengths) {
    require(A.shape(0) == A.shape(1), "A: square");
    for (size_t k : lengths) require(k >= A.shape(0), "a vector shorter than A");
    return static_cast<int>(A.shape(0));
}

template <class T>
void expose_lu(nb::module_& m) {
    m.def("lu_factor", [](Square<T> A, Vector<int> piv) {
        core::sim::lu_factor(A.data(), square(A, {piv.shape(0)}), piv.data());
    });
    m.def("lu_solve", [](Square<T> LU, Vector<int> piv, Vector<T> b) {
        core::sim::lu_solve(LU.data(), square(LU, {piv.shape(0), b.shape(0)}), piv.data(), b.data());
    });
    m.def("envelope_lu_factor", [](Square<T> A, Vector<int> piv, Vector<int> env) {
        const int n = square(A, {piv.shape(0), env.shape(0) / 3});
        core::sim::envelope_lu_factor(A.data(), n, piv.data(), env.data());
    });
    m.def("envelope_lu_solve", [](Square<T> LU, Vector<int> piv, Vector<int> env, Vector<T> b) {
        const int n = square(LU, {piv.shape(0), env.shape(0) / 3, b.shape(0)});
        core::sim::envelope_lu_solve(LU.data(), n, piv.data(), env.data(), b.data());
    });
    // b <- (mu I - J)^-1 b by the reduction to the velocities (radau's, second_order.hpp); blocks: the joints' first
    // velocity coordinates, then nv
    m.def("reduced_solve", [](Square<double> J, Vector<int> blocks_, T mu, Vector<T> b) {
        const int n = square(J, {b.shape(0)});
        std::vector<int> blocks(blocks_.data(), blocks_.data() + blocks_.shape(0));
        require(blocks.size() >= 2 && blocks.front() == 0 && 2 * blocks.back() <= n,
                "blocks: 0, the joints' first velocity coordinates, then nv (2 nv <= n)");
        for (size_t j = 0; j + 1 < blocks.size(); ++j) require(blocks[j] < blocks[j + 1], "blocks: increasing");
        core::sim::ReducedSystem<T> S;
        S.factor(J.data(), n, blocks, mu);
        S.solve(b.data());
    });
}

}  // namespace

void expose_ode(nb::module_& m) {
    using namespace nb::literals;
    // One run of `method` on z' = f(t, z) from (0, z) to t_end (z advanced in place), samples at out_t into out_t
    // (rewritten) and out_z (T, n); statistics and switches into their record arrays, as _core.run.
    m.def("solve_ode", [](const std::string& method, nb::object f, nb::handle z_, double t_end, nb::handle out_t_,
                          nb::handle out_z_, nb::dict opt_, nb::handle stats_, nb::handle sw_) {
        const Output z = output_of(z_, 1), out_t = output_of(out_t_, 1), out_z = output_of(out_z_, 2);
        const long n = length(z), T = length(out_t);
        require(length(out_z) == T && out_z.shape(1) == n, "out_z: (T, n)");
        const core::sim::Options opt = options_of(opt_);
        require(opt.nc >= 0 && opt.nc + opt.nvel <= n && opt.ne >= 0 && opt.ne <= n, "options: sizes");
        auto [stats_raw, stats_ptr] = record_of(stats_, sizeof(core::sim::Stats), "stats");
        auto [sw_raw, sw_ptr] = record_of(sw_, sizeof(core::sim::Switch) * core::sim::MAX_SWITCHES, "switches");
        core::sim::Stats st;
        std::memcpy(&st, stats_ptr, sizeof st);
        std::vector<core::sim::Switch> sw;
        PyODE p(f, static_cast<int>(n), out_t.data(), out_z.data());
        {
            nb::gil_scoped_release unlocked;
            core::sim::run_method(method.c_str(), p, z.data(), static_cast<int>(n), 0.0, t_end, out_t.data(), T, opt,
                                  st, sw);
        }
        std::memcpy(stats_ptr, &st, sizeof st);
        if (!sw.empty())
            std::memcpy(sw_ptr, sw.data(), sizeof(core::sim::Switch) * std::min<size_t>(sw.size(), core::sim::MAX_SWITCHES));
        p.raise_if_failed();
    }, "method"_a, "f"_a, "z"_a, "t_end"_a, "out_t"_a, "out_z"_a, "options"_a, "stats"_a, "switches"_a);

    expose_lu<double>(m);  // (dense and envelope, real and complex: overloads by dtype)
    expose_lu<std::complex<double>>(m);
    m.def("spectral_radius", [](Square<const double> J, int ne) {
        const int n = square(J, {});
        require(ne >= 0 && ne <= n, "ne: in [0, n]");
        return core::sim::spectral_radius(J.data(), n, ne);
    });
}

}  // namespace bind
