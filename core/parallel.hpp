// Batches of states over threads, with a deadline (the C++ side of dynamics/parallel.py).
//
// Each thread has its own Data (allocated before any thread starts, so a failed allocation is an exception on the
// calling thread, never in a worker) and takes the batch's states from one shared counter, CHUNK at a time, until
// none are left: a thread that the machine slows down (another process on its core) takes fewer chunks instead of
// holding the whole batch up, as one fixed slice per thread did.  Each state is computed by the same kernel
// whichever thread takes it, so the numbers do not depend on the split.  With a deadline, a thread looks at the
// clock before each chunk.  A state whose kernel returns a code >= 0 (a singular joint) ends its thread's work,
// and no chunk past it is started; every state before it is still computed, so the status reports the first
// such state of the batch.
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
// States a thread takes from the shared counter at a time (and between two looks at the clock).
constexpr long CHUNK = 16;

// Runs kernel(b, data) -> int for b in [0, B) on up to nthreads threads; `seconds` from now is the deadline
// (infinite: none).  The caller has released the GIL.  min_parallel and chunk: for kernels much heavier than one
// state's dynamics (a simulator's period), fewer states are worth a thread and a smaller chunk balances them.
template <class Kernel>
BatchStatus run_batch(const Model& model, long B, int nthreads, double seconds, const Kernel& kernel,
                      long min_parallel = MIN_PARALLEL_BATCH, long chunk = CHUNK) {
    using clock = std::chrono::steady_clock;
    const bool timed = std::isfinite(seconds);
    const auto t_end = clock::now() + std::chrono::duration_cast<clock::duration>(
                                          std::chrono::duration<double>(std::min(std::max(seconds, 0.0), 1e7)));
    const int nt = B < min_parallel ? 1 : static_cast<int>(std::max(1L, std::min<long>(nthreads, B)));
    std::vector<Data> datas(nt, Data(model));
    std::vector<BatchStatus> status(nt);
    std::atomic<long> next{0};       // the first state no thread has taken
    std::atomic<long> first_bad{B};  // the first failed state seen so far: no chunk at or past it starts
    auto work = [&](int t) {
        BatchStatus& s = status[t];
        Data& data = datas[t];
        for (;;) {
            const long lo = next.fetch_add(chunk, std::memory_order_relaxed);
            if (lo >= first_bad.load(std::memory_order_relaxed)) return;
            if (timed && clock::now() > t_end) {
                s.expired = true;
                return;
            }
            const long hi = std::min(B, lo + chunk);
            for (long b = lo; b < hi; ++b) {
                int code = kernel(b, data);
                if (code >= 0) {
                    s.failed = b, s.code = code;
                    long seen = first_bad.load(std::memory_order_relaxed);
                    while (b < seen && !first_bad.compare_exchange_weak(seen, b, std::memory_order_relaxed)) {
                    }
                    return;
                }
                ++s.done;
            }
        }
    };
    std::vector<std::thread> threads;
    try {
        for (int t = 1; t < nt; ++t) threads.emplace_back(work, t);
    } catch (const std::system_error&) {  // no thread to be had: this one takes what the others would have
    }
    work(0);
    for (auto& th : threads) th.join();
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
