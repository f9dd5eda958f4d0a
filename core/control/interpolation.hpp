// Interpolation of the torque sources' references: the segment of a time table, and quintic Hermite
// interpolation of [position, velocity, acceleration] samples (C2, and consistent: v = q', a = v').
#pragma once

namespace core::control {

// k with times[k] <= t < times[k+1], clipped to [0, N-2] (N >= 2).
int segment(const double* times, int N, double t);

// The quintic Hermite interpolation at t (clamped to the ends) of the reference rows [q (m), v (m), a (m)] of the
// (N, 3m) row-major table, into q, v, a (m each).
void reference_at(const double* times, int N, const double* table, int m, double t, double* q, double* v, double* a);

}  // namespace core::control
