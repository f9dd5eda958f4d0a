// The configuration manifold, apart from time stepping (joints.hpp has each joint's formulas).
//
// integrate(q, v, dt) moves q along the constant velocity v for dt (Pinocchio's integrate(q, v dt)): q + v dt
// for 1-dof joints, the SE(3) exponential for the free joint, the SO(3) one for the spherical joint, the SE(2)
// one for the planar joint; quaternions and (cos, sin) stay unit length.  difference(q0, q1) is its inverse,
// the tangent d with integrate(q0, d, 1) == q1 (the logarithms of M0^-1 M1).
//
// The simulation's steppers work in a chart around the configuration q0 at the start of a step: the unknown is
// a tangent delta and q = retract(q0, delta) (q0 + delta for 1-dof joints, p0 + delta_p and quat0 (x)
// exp(delta_theta) for the free joint, ...); chart_difference(q0, q1) is its inverse.
#pragma once

#include "data.hpp"

namespace core {

// out (nq) = integrate(q, v, dt); delta (nv) is scratch.
void integrate(const Model& model, const double* q, const double* v, double dt, double* delta, double* out);
// out (nv) = difference(q0, q1) (Pinocchio's).
void difference(const Model& model, const double* q0, const double* q1, double* out);
// q (nq) = retract(q0, delta) in the chart.
void retract(const Model& model, const double* q0, const double* delta, double* q);
// out (nv): the chart tangent d with retract(q0, d) == q1.
void chart_difference(const Model& model, const double* q0, const double* q1, double* out);
// out (nv) = d(delta)/dt for velocity v at q = retract(q0, delta).
void chart_rate(const Model& model, const double* q, const double* delta, const double* v, double* out);
// delta (nv): the chart coordinates of integrate(q, v, dt) around q.
void integrate_delta(const Model& model, const double* q, const double* v, double dt, double* delta);
// mag (nv): the magnitudes of q's coordinates for the simulation's relative tolerance (joint_magnitudes).
void magnitudes(const Model& model, const double* q, double* mag);

}  // namespace core
