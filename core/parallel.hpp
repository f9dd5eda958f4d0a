// Batches of states over threads, with a deadline (the C++ side of dynamics/parallel.py).
//
// A batch is split into one contiguous chunk per thread; each thread has its own Data (allocated before any
// thread starts, so a failed allocation is an exception on the calling thread, never in a worker) and works
// through its chunk, looking at the clock every 16 states when a deadline is set.  A state whose kernel
// returns a code >= 0 (a singular joint) ends its chunk; the status reports the first such state.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <memory>
#include <cmath>
#include <system_error>
#include <thread>
#include <vector>

#include "data.hpp"

namespace core {

struct BatchStatus {
    long done = 0;         // states finished, over every thread
    bool expired = false;  // the deadline passed before the batch was done
    long failed = -1;      // the first state whose kernel returned a code >= 0, or -1
    int code = -1;         // that code (a body index)
};

// Below this many states a batch runs on the calling thread (starting a thread costs ~20-50 us).
constexpr long MIN_PARALLEL_BATCH = 64;

// Runs kernel(b, data) -> int for b in [0, B) on up to nthreads threads; `seconds` from now is the deadline
// (infinite: none).  The caller has released the GIL.
template <class Kernel>
BatchStatus run_batch(const Model& model, long B, int nthreads, double seconds, const Kernel& kernel) {
    using clock = std::chrono::steady_clock;
    const bool timed = std::isfinite(seconds);
    const auto t_end = clock::now() + std::chrono::duration_cast<clock::duration>(
                                          std::chrono::duration<double>(std::min(std::max(seconds, 0.0), 1e7)));
    const int nt = B < MIN_PARALLEL_BATCH ? 1 : static_cast<int>(std::max(1L, std::min<long>(nthreads, B)));
    std::vector<Data> datas(nt, Data(model));
    std::vector<BatchStatus> status(nt);
    auto work = [&](int t) {
        const long lo = B * t / nt, hi = B * (t + 1) / nt;
        BatchStatus& s = status[t];
        for (long b = lo; b < hi; ++b) {
            if (timed && ((b - lo) & 15) == 0 && clock::now() > t_end) {
                s.expired = true;
                return;
            }
            int code = kernel(b, datas[t]);
            if (code >= 0) {
                s.failed = b, s.code = code;
                return;
            }
            ++s.done;
        }
    };
    std::vector<std::thread> threads;
    int t = 1;
    try {
        for (; t < nt; ++t) threads.emplace_back(work, t);
    } catch (const std::system_error&) {  // no thread to be had: the rest on this one
    }
    work(0);
    for (auto& th : threads) th.join();
    for (int r = t; r < nt; ++r) work(r);
    BatchStatus out;
    for (const BatchStatus& s : status) {
        out.done += s.done;
        out.expired = out.expired || s.expired;
        if (s.failed >= 0 && (out.failed < 0 || s.failed < out.failed)) out.failed = s.failed, out.code = s.code;
    }
    return out;
}

// Workspaces of a batch's threads, made (and sized) by the caller before the threads start, so that a failed
// allocation is an exception on the calling thread: min(nthreads, B) of them (run_batch uses at most that many
// threads), at least one.  A worker claims a free one the first time it shows its Data and keeps it, as
// DerivativesPool (derivatives_data.hpp) does.
template <class W>
class WorkspacePool {
public:
    explicit WorkspacePool(std::vector<W>& work)
        : n_(static_cast<int>(work.size())), owner_(new std::atomic<const Data*>[n_]), work_(work) {
        for (int t = 0; t < n_; ++t) owner_[t].store(nullptr);
    }
    W& of(const Data& data) {
        for (int t = 0; t < n_; ++t) {
            const Data* seen = nullptr;
            if (owner_[t].compare_exchange_strong(seen, &data) || seen == &data) return work_[t];
        }
        std::terminate();  // more Data than workspaces: the caller made too few
    }

private:
    int n_;
    std::unique_ptr<std::atomic<const Data*>[]> owner_;
    std::vector<W>& work_;
};

}  // namespace core
