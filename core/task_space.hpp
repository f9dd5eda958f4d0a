// Task-space (operational-space) inertia (Khatib 1987; Featherstone 2008, sec. 9.3): for a frame's Jacobian J
// (chosen rows and reference), Lambda = (J M^-1 J^T)^-1.  The core forms J M^-1 J^T over the frame's support
// columns only (M^-1 by minverse); its inverse, by a symmetric eigendecomposition that also gives the condition
// number, is taken by the caller (dynamics/task_space.py).
#pragma once

#include "data.hpp"

namespace core {

// JMJ (r x r, row-major) = J[rows] M^-1 J[rows]^T at q for frame f in reference ref; rows: r indices in [0, 6).
// Returns -1, or a body whose joint makes M singular.
int jminvjt(const Model& model, Data& data, const double* q, int f, int ref, const int* rows, int r, double* JMJ);

}  // namespace core
