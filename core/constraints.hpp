// Closed loops and coupled joints: the residual phi(q), its Jacobian Phi_q and Phi_q_dot v (the C++ side of
// dynamics/constraints.py, whose docstring has the rows of each kind; the numbers here are the same, in the same
// order of operations).
//
// Each loop constraint holds two anchors fixed on bodies, (body_a, R_a, p_a) and (body_b, R_b, p_b), poses in the
// body frames; with x_A, x_B their world origins and R_A, R_B their world axes, in world axes:
//
//   kind       rows  phi(q)                              velocity rows Phi_q v
//   POINT      3     x_A - x_B                           v_A(x_A) - v_B(x_B)
//   WELD       6     [x_A - x_B; log(R_A R_B^T)]          [v_A(x_A) - v_B(x_B); w_A - w_B]
//   REVOLUTE   5     [x_A - x_B; t_k . (u_B x u_A)]       [v_A(x_A) - v_B(x_B); t_k . (w_A - w_B)], k = 1, 2
//   COUPLING   1     q_f - (multiplier q_l + offset)     v_f - multiplier v_l
//
// u_A, u_B: the anchors' z axes (the hinge), t_1, t_2: anchor a's x and y axes.  gamma = Phi_q_dot v is the
// difference of the anchors' classical bias accelerations, and for the hinge rows (w_A x t_k) . (w_A - w_B) +
// t_k . (alpha_A - alpha_B).  Kinematics in world coordinates at the world origin (Featherstone 2008, sec. 2.9):
//     oS_k = (oR_i S_w, oR_i S_v + op_i x oR_i S_w),   V_i = V_p + oS_i qd_i,   A_i = A_p + V_i x (oS_i qd_i).
//
//   field   size     meaning
//   kind    nc       POINT, WELD, REVOLUTE or COUPLING
//   row     nc       the constraint's first row in phi
//   body    nc x 2   the bodies of anchors a and b (-1: the world)
//   R, p    nc x 2   the anchors' axes and origins in their bodies' frames (hinge: z = the axis)
//   idx     nc x 4   coupling: (q index, v index) of the follower, then of the leader
//   coef    nc x 2   coupling: (multiplier, offset)
#pragma once

#include <vector>

#include "data.hpp"

namespace core {

enum ConstraintKind { POINT = 0, WELD = 1, REVOLUTE = 2, COUPLING = 3 };

// Rows of each kind.
inline int constraint_rows(int kind) { return kind == POINT ? 3 : kind == WELD ? 6 : kind == REVOLUTE ? 5 : 1; }

struct Constraints {
    int nc = 0, m = 0;              // constraints, rows
    int nb = -1, nq = -1, nv = -1;  // the sizes of the model check() found them consistent with
    std::vector<int> kind, row, body, idx;
    std::vector<Mat3> R;
    std::vector<Vec3> p;
    std::vector<double> coef;
};

// Checks every index and size of constraints filled from outside against the model (rows consecutive, bodies and
// coordinates in range, finite numbers) and records the model's sizes; throws std::invalid_argument naming the
// first inconsistency.
void check(const Model& model, Constraints& con);

// The constraint terms' scratch: motion axes in the world (nv), body velocities and bias accelerations (nb), world
// origin, world axes.
struct ConstraintWork {
    std::vector<Motion> oS, V, A;
    void resize(const Model& model) { oS.resize(model.nv), V.resize(model.nb), A.resize(model.nb); }
};

// phi (m) at q; with J: J = Phi_q (m x nv, row-major, overwritten); with gamma: gamma = Phi_q_dot v (m).  J and
// gamma may be null.  Uses data.oMi and data.X.
void constraint_terms(const Model& model, const Constraints& con, Data& data, ConstraintWork& w, const double* q,
                      const double* v, double* phi, double* J, double* gamma);

}  // namespace core
