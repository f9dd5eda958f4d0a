// What every run of a solver takes from Python (bindings/simulation.cpp's robot runs, bindings/ode.cpp's plain
// ODEs): the options and the record arrays the statistics and the switches are written into.
#pragma once

#include <cstdint>
#include <memory>
#include <utility>

#include "arrays.hpp"
#include "simulation/solver.hpp"

namespace bind {

// The solver's options: a tuple of dynamics.simulation.solvers.Options' fields in their order (the core's Options),
// then optionally the deadline (simulate's runs: no names parsed per call), or the dict of those fields by name
// ("deadline" optional).
core::sim::Options options_of(nb::handle opt);

// A record array's bytes, held (its buffer exported) while the returned holder lives.
struct RecordBuffer;
struct RecordBufferRelease {
    void operator()(RecordBuffer* b) const;
};
using RecordHold = std::unique_ptr<RecordBuffer, RecordBufferRelease>;

// A writable C-contiguous record array's bytes, at least `size` of them: the statistics (a (1,) STATS array) or the
// switch log (MAX_SWITCHES SWITCH rows).  Through the buffer protocol: no view made per call.
std::pair<RecordHold, uint8_t*> record_of(nb::handle x, size_t size, const char* name);

}  // namespace bind
