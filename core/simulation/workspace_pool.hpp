// Workspaces a run borrows from its thread's pool and gives back when its problem goes: a warm simulate call then
// allocates none of them (Panda's one-step call made ~70 allocations for its Data and its Jacobian's workspace).
//
// A pooled workspace is scratch: whoever takes one sizes it for its model (Data::resize, JacobianWork::reset) and
// writes every field before reading it; the pool keeps the capacity, not the contents.  It is owned by one problem
// at a time (never shared: two simulators on one thread each hold their own), and goes back to the pool of the
// thread that destroys its problem; each thread keeps at most KEEP of a kind.
#pragma once

#include <memory>
#include <vector>

namespace core::sim {

template <class W>
class WorkspacePool {
public:
    static constexpr size_t KEEP = 4;

    static std::unique_ptr<W> take() {
        Free* f = free_list();
        if (!f || f->items.empty()) return std::make_unique<W>();
        std::unique_ptr<W> w = std::move(f->items.back());
        f->items.pop_back();
        return w;
    }
    static void give(W* w) {
        Free* f = free_list();
        if (f && f->items.size() < KEEP)
            f->items.emplace_back(w);
        else
            delete w;
    }

private:
    struct Free {
        std::vector<std::unique_ptr<W>> items;
        ~Free() { gone() = true; }
    };
    // (a problem destroyed while its thread exits, after the list: gone() is trivially destructible, still readable)
    static bool& gone() {
        thread_local bool g = false;
        return g;
    }
    static Free* free_list() {
        if (gone()) return nullptr;
        thread_local Free f;
        return &f;
    }
};

template <class W>
struct GiveBack {
    void operator()(W* w) const { WorkspacePool<W>::give(w); }
};

// A workspace borrowed from the calling thread's pool (empty until borrowed).
template <class W>
using Pooled = std::unique_ptr<W, GiveBack<W>>;

template <class W>
Pooled<W> from_pool() {
    return Pooled<W>(WorkspacePool<W>::take().release());
}

}  // namespace core::sim
