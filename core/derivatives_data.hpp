// The workspace of the analytical derivatives (rnea_derivatives.hpp, aba_derivatives.hpp): one per call or per
// thread, never shared, as Data (data.hpp), whose fields are in each body's frame while these are in the world's.
// Sizes in the comments (nb bodies, nv velocity coordinates); motions and forces at the world origin, core order.
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <memory>
#include <vector>

#include "data.hpp"

namespace core {

struct DerivativesData {
    int nb = -1, nv = -1;  // the sizes it was made for

    // per body, the forward pass
    std::vector<Transform> oM;  // nb: body i in the world
    std::vector<Motion> ov;     // nb: velocity
    std::vector<Motion> oa;     // nb: acceleration, gravity included (the world accelerates up)
    // per body, written by the forward pass and summed over the subtree by the backward pass
    std::vector<Inertia> Y;     // nb: rigid-body inertia about the world origin
    std::vector<Mat3> B;        // nb: dY = [[B, 0], [-2 [hf]x, 0]], the variation of Y along ov
    std::vector<Vec3> hf;       // nb
    std::vector<Force> F;       // nb: f_i = Y_i oa_i + ov_i x* Y_i ov_i - f_ext_i

    // per velocity coordinate k of joint i (parent p)
    std::vector<Motion> J;    // nv: J_k = oX_i S_k, the joint axis in the world
    std::vector<Motion> dV;   // nv: ov_p x J_k
    std::vector<Motion> dAq;  // nv: oa_p x J_k + ov_p x dV_k
    std::vector<Motion> dAv;  // nv: ov_i x J_k + dV_k
    std::vector<Force> Fa;    // nv: Y_i J_k
    std::vector<Force> Fv;    // nv: dY_i J_k + Y_i dAv_k
    std::vector<Force> Fq;    // nv: dY_i dV_k + Y_i dAq_k (+ J_k x* F_i once i's own rows are done)
    std::vector<Vec3> lv;     // nv: the angular half of dY_i^T J_k (its linear half is zero)

    // the ABA derivatives: the acceleration (nv) and the RNEA derivatives at it (nv x nv each, row-major, then 4
    // zeros: the product with M^-1 reads a block of 4 columns past the last), the product's row list K (nv)
    std::vector<double> qdd, dtau_dq, dtau_dv, M;
    std::vector<int> K;

    DerivativesData() = default;
    explicit DerivativesData(const Model& model) { resize(model); }
    void resize(const Model& model);
};

// The calling thread's workspace, sized for `model` (a single call's: no allocation once warm).
DerivativesData& thread_derivatives_data(const Model& model);

// One workspace per thread of a batch (core::run_batch hands its kernel a Data per thread, not this): all are
// allocated here, on the calling thread, as run_batch allocates its Data, so a failed allocation is an exception
// there and never in a worker.  A worker claims a free one the first time it shows its Data and keeps it; each
// Data is used by one thread at a time, so each workspace is too.
class DerivativesPool {
public:
    // Enough for a batch of B states on nthreads threads (run_batch uses at most min(nthreads, B) of them).
    DerivativesPool(const Model& model, long B, int nthreads)
        : n_(static_cast<int>(std::max(1L, std::min<long>(std::max(nthreads, 1), B)))),
          owner_(new std::atomic<const Data*>[n_]),
          work_(n_, DerivativesData(model)) {
        for (int t = 0; t < n_; ++t) owner_[t].store(nullptr);
    }
    // The workspace of the thread working with `data`.
    DerivativesData& of(const Data& data) {
        for (int t = 0; t < n_; ++t) {
            const Data* seen = nullptr;
            if (owner_[t].compare_exchange_strong(seen, &data) || seen == &data) return work_[t];
        }
        std::terminate();  // more Data than threads: run_batch broke its own rule
    }

private:
    int n_;
    std::unique_ptr<std::atomic<const Data*>[]> owner_;
    std::vector<DerivativesData> work_;
};

}  // namespace core
