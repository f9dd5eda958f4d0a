// What every run of a solver takes from Python (bindings/simulation.cpp's robot runs, bindings/ode.cpp's plain
// ODEs): the options dict and the record arrays the statistics and the switches are written into.
#pragma once

#include <cstdint>
#include <utility>

#include "arrays.hpp"
#include "simulation/solver.hpp"

namespace bind {

// The solver's options from the dict dynamics.simulation.solvers.Options makes (its fields by name; "deadline"
// optional).
core::sim::Options options_of(const nb::dict& opt);

// A record array's bytes (its uint8 view, kept alive by the returned object) of at least `size` bytes: the
// statistics (a (1,) STATS array) or the switch log (MAX_SWITCHES SWITCH rows).
std::pair<nb::object, uint8_t*> record_of(nb::handle x, size_t size, const char* name);

}  // namespace bind
