// Analytical derivatives of constrained forward dynamics (Pinocchio's computeConstraintDynamicsDerivatives,
// extended to every constraint of constraints.hpp: point, weld, hinge and coupling; the C++ side of
// dynamics/constrained_derivatives.py, whose docstring has the derivation; the same steps in the same order).
//
// At the solution (a, lambda) of constrained_forward_dynamics the KKT conditions hold:
//
//     r1 = ID(q, v, a) - J(q)^T lambda - tau = 0,
//     r2 = J a + gamma + 2 alpha J v + beta^2 phi = 0.
//
// Differentiating along x = q (tangent space), v, tau with (a, lambda) held in the partials:
//
//     [M  -J^T] [da  ]     [dr1/dx]      dr1/dq = dID/dq - d(J^T lambda)/dq,  dr1/dv = dID/dv,  dr1/dtau = -1
//     [J    0 ] [dlam] = - [dr2/dx],     dr2/dq, dr2/dv: the rows' derivatives at fixed a
//
// solved like the dynamics (K = J M^-1 J^T): with X = -dr1/dx and Z = -dr2/dx,
//
//     dlam = K^+ (Z - J M^-1 X),    da = M^-1 (X + J^T dlam).
//
// dID/dq, dID/dv: the RNEA derivatives (rnea_derivatives.hpp) at the constrained a; the constraint partials are
// taken in the world frame on their forward pass (J_j, dV_j, dAq_j, dAv_j): along q_j a body b's velocity and
// acceleration change by dV_j + J_j x ov_b and dAq_j + dV_j x ov_b + J_j x oa_b, along v_j its acceleration by
// dAv_j + J_j x ov_b (j on b's support), and a point x on b moves by dx = J_j^v + J_j^w x x.  With
// vel = ov^v + ov^w x x and acc = oa^v + oa^w x x + ov^w x vel:
//
//     d vel = dov^v + dov^w x x + ov^w x dx,    d acc = doa^v + doa^w x x + oa^w x dx + dov^w x vel + ov^w x d vel
//
// and the weld's phi = log(R_A R_B^T) has the derivative Jl^-1(phi) (dth_A - R_A R_B^T dth_B).  J^T lambda is the
// sum over anchors of J_b^T F, F the world force at the origin; at fixed lambda, for k on the support of b,
//
//     d(J_k . F)/dq_j = J_k . dF/dq_j + [j on the support of k's body] F . (J_j x J_k).
//
// Redundant rows (K singular, lambda the minimum-norm multiplier): the minimum-norm solve misses the term
// N d(J w)/dq with w = J^+ lambda and N the projector onto null(J^T) (Golub and Pereyra 1973), added here.
#pragma once

#include <vector>

#include "constrained_dynamics.hpp"
#include "derivatives_data.hpp"

namespace core {

// The workspace of one state (one per call or per thread, never shared); sizes in the comments.
struct ConstrainedDerivativesData {
    DerivativesData rd;                   // the RNEA derivatives' forward pass and composites
    ConstrainedData cd;                   // the KKT solve's factors (M = L^T L, Y, K)
    std::vector<double> dq, dv, M, P;     // nv x nv: dtau/dq, dtau/dv, M, d(J^T lambda)/dq
    std::vector<double> G, H;             // m x nv: dr2/dq, dr2/dv
    std::vector<double> XT, RT;           // 3 nv x nv, 3 nv x m: the columns of X and Z, then of da and dlam
    std::vector<double> K, Kinv, YT;      // m x m, m x m, nv x m
    std::vector<double> x, lam, a;        // m, m, nv
    std::vector<char> anc;                // nb x nb: anc[i nb + j] = 1 where j is i or an ancestor of i
    std::vector<int> owner;               // nv: each coordinate's body
    std::vector<double> JJ, LN, Gm, Q;    // m x m: the null-space term's scratch
    std::vector<int> piv;                 // m
    std::vector<double> s, t, w, zero;    // m, m, nv, nv
    ConstrainedDerivativesData() = default;
    ConstrainedDerivativesData(const Model& model, const Constraints& con) { resize(model, con); }
    void resize(const Model& model, const Constraints& con);
};

// out (3 x (nv + m) x nv, row-major): [da; dlam] along q (tangent space), v and tau at (q, v, tau) with gravity and
// Baumgarte gains alpha, beta.  Returns -1, or the body whose joint makes M singular.
int constrained_forward_dynamics_derivatives(const Model& model, const Constraints& con, Data& data,
                                             ConstrainedDerivativesData& w, const double* q, const double* v,
                                             const double* tau, const Vec3& gravity, double alpha, double beta,
                                             double* out);

}  // namespace core
