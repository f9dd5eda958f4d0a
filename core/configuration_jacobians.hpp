// The Jacobians of the configuration update, joint by joint (Pinocchio's dIntegrate and dDifference).
//
// integrate(q, v) is q (+) v: q + v for 1-dof joints, and M Exp(xi) for the free joint (M its pose, xi = (v_lin,
// omega) its body twist, the SE(3) exponential), the spherical (SO(3)) and the planar joint (SE(2)); difference is
// its inverse, q1 (-) q0 = Log(M0^-1 M1).  Derivatives with respect to q are in the tangent space, so every
// Jacobian is (nv, nv) and block diagonal, one block per joint:
//
//     d(q (+) v)/dq = Ad(Exp(xi))^-1,           d(q (+) v)/dv = Jr(xi)
//     d(q1 (-) q0)/dq1 = Jr(d)^-1,              d(q1 (-) q0)/dq0 = -Jr(d)^-1 Ad(Exp(d))^-1,   d = q1 (-) q0
//
// with Ad(R, p) = [[R, [p] R], [0, R]] in the (linear, angular) order of a free joint's v, and Jr the right
// Jacobian of SE(3) (Barfoot, "State estimation for robotics", 2017, eqs. 7.83-7.86, with Jr(xi) = Jl(-xi)):
//
//     Jl(xi) = [[Jl(phi), Q(rho, phi)], [0, Jl(phi)]],   Jl(phi) = 1 + (1 - cos t)/t^2 [phi] + (t - sin t)/t^3 [phi]^2
//
// For 1-dof joints the blocks are 1 (and -1 for dq0).  The spherical and planar joints' groups are subgroups of
// SE(3) (rotations; motions in the plane of the joint's in-plane directions u, w, about its axis): their blocks are
// the rows and columns of the SE(3) blocks at their twist (angular; (v_u, v_w, w_axis)).
#pragma once

#include "model.hpp"

namespace core {

// Jq = d(q (+) v)/dq and Jv = d(q (+) v)/dv (nv x nv each, row-major, every entry written): they depend on v only.
void integrate_jacobians(const Model& model, const double* v, double* Jq, double* Jv);

// J0 = d(q1 (-) q0)/dq0 and J1 = d(q1 (-) q0)/dq1 (nv x nv each) for d = difference(q0, q1).  Returns false if a
// block Jr(d) is singular (an angle of 2 pi, which difference never gives).
bool difference_jacobians(const Model& model, const double* d, double* J0, double* J1);

}  // namespace core
