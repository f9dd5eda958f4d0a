// Analytical derivatives of the torque sources with respect to the state: dtau/dq (in the tangent space, nv
// columns, along q (+) dq as Pinocchio) and dtau/dv; one small function per kind, one switch (source_derivatives).
//
// PD, tau = kp e + kd (v_target - v) + tau_ff with e = q_target (-) q the chart difference:
//     dtau/dv = -diag(kd),   dtau/dq = diag(kp) de/dq, de/dq block diagonal, one block per joint:
//         1-dof joint  -1
//         spherical    -Jl(e)^-1                     (log(Exp(-dw) R^T R_target) = e - Jl(e)^-1 dw + ...)
//         free         [[-R, 0], [0, -Jl(e_rot)^-1]] (the position error in the world frame, the velocity in the body)
//         planar       [[-R(theta), 0], [0, -1]]
//     with Jl^-1(phi) = 1 - [phi]/2 + c [phi]^2 the inverse left Jacobian of SO(3).
// Computed torque, tau = RNEA(q, v, a*) - tau_passive(q, v), a* = a_ref + kd (v_ref - v) + kp (q_ref - q):
//     dtau/dq = dRNEA/dq (q, v, a*) - M diag(kp) - dtau_passive/dq,  dtau/dv = dRNEA/dv (q, v, a*) - M diag(kd) - ...
// (computed_torque_derivatives.cpp).  Operational space: operational_space_derivatives.hpp (1-dof joints; other
// models are differenced).  Zero, constant and tables depend on t alone: zero.  Python callables have none: false,
// and the caller differences the source (source_derivatives_tangent).
#pragma once

#include "sources.hpp"

namespace core::control {

// dq = dtau/dq (tangent space), dv = dtau/dv (nv x nv, row-major) at (t, q, v); false (nothing written) for a kind
// without an analytical derivative.
bool source_derivatives(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws, double t,
                        const double* q, const double* v, double* dq, double* dv);

// As source_derivatives, else central differences of the source along q (+) h e_k and v + h e_k.  Returns true if
// analytical.
bool source_derivatives_tangent(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws,
                                double t, const double* q, const double* v, double* dq, double* dv);

// The computed torque's (computed_torque_derivatives.cpp; every entry written).
bool computed_torque_derivatives(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws,
                                 double t, const double* q, const double* v, double* dq, double* dv);

// c of Jl(phi)^-1 = 1 - [phi]/2 + c [phi]^2 (the same c as Jr^-1's).
double so3_jinv_c(double p0, double p1, double p2);

// The closed loop a = ABA(q, v, tau_s(t, q, v) + tau_p(q, v)) of a model without contact: da_dq (tangent space),
// da_dv = the ABA derivatives at that torque + M^-1 (dtau_s + dtau_p) (dynamics/torque_derivatives.py).  Returns
// -1, or a body whose joint makes M singular (then nothing is valid).
int closed_loop_derivatives(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws, double t,
                            const double* q, const double* v, double* da_dq, double* da_dv);

constexpr double FD_STEP = 6e-6;  // central differences (relative, ~ eps^(1/3))

}  // namespace core::control
