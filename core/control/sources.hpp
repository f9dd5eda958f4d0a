// The torque sources a simulation applies (dynamics/torques.py has their laws; dynamics/control/validation.py builds
// them from the user's arguments and checks every one), and their evaluation: one small function per kind, one
// switch on the kind (source_torques).
//   zero:             tau = 0
//   constant:         tau = gains[0]
//   table:            tau = the rows of `table` (N, nv) interpolated linearly or held (zero-order hold) at t
//   PD:               tau = kp (q_target (-) q) + kd (v_target - v) + tau_ff, gains = [kp; kd; v_target; tau_ff]
//   computed torque:  tau = RNEA(q, v, a_ref + kd (v_ref - v) + kp (q_ref - q)) - tau_passive(q, v), the reference
//                     [q, v, a] rows of `table` (N, 3 nv) interpolated by quintic Hermite polynomials
//   callable:         a Python function f(t, q, v) (the bindings' TorqueCallback)
//   operational space: operational_space.hpp
#pragma once

#include <vector>

#include "data.hpp"
#include "derivatives_data.hpp"
#include "passive.hpp"

namespace core::control {

enum SourceKind { ZERO = 0, CONSTANT = 1, TABLE_LINEAR = 2, TABLE_ZOH = 3, PD = 4, COMPUTED_TORQUE = 5, CALLABLE = 6,
                  OPERATIONAL_SPACE = 7 };

// A torque given by code outside the core (a Python callable): false when it failed (the implementation keeps the
// error to raise it after the run; the simulation stops).
class TorqueCallback {
public:
    virtual ~TorqueCallback() = default;
    virtual bool torques(double t, const double* q, const double* v, double* tau) = 0;
    virtual bool failed() const = 0;  // a call failed: the simulation stops
};

struct Source {
    int kind = ZERO;
    std::vector<double> times;   // (N,) table or reference times
    std::vector<double> table;   // (N, table_cols) row-major: torques, the reference [q, v, a] or [p, pdot, pddot]
    int table_cols = 0;
    std::vector<double> gains;   // (4, nv) rows kind-dependent: constant tau | kp, kd, v_target, tau_ff
    std::vector<double> qref;    // (nq,) PD target; operational space: the posture
    TorqueCallback* callback = nullptr;  // CALLABLE
    // operational space only
    int frame = -1;
    std::vector<int> rows;            // task rows of [linear; angular]
    double task_gains[2][6] = {};     // Kp, Kd per task row
    std::vector<double> orientation;  // (N, 12): R_k (9) and psi_k = log(R_k+1 R_k^T) (3)
    double damping = 0.0;             // added to the diagonal of J M^-1 J^T
    int samples() const { return static_cast<int>(times.size()); }
};

// The sources' scratch, one per simulation (per thread).
struct SourceWorkspace {
    Data data;                                  // the RNEA's, M^-1's, the Jacobian's
    std::vector<double> e, qr, vr, ar, pas;     // (nv,) / reference rows
    std::vector<double> J, Minv, JM, tp, zero;  // operational space: J (6 x nv), M^-1, J M^-1 (6 x nv), tau_p, zeros
    double jdv[6] = {}, y[6] = {}, Lam[36] = {}, A[36] = {};  // Jdot v, the task's y, Lambda, J M^-1 J^T + d 1
    DerivativesData dd;                         // the derivatives': the RNEA derivatives' workspace
    std::vector<double> M, DM, pq, pv;          // M, d(M s)/dq (nv x nv), the passive derivatives' diagonals
    // kind: the source kind it serves; the RNEA's, M^-1's, the operational space's and the derivatives' workspaces
    // (data, J .. zero, dd, M .. pv) are made only for the kinds that read them (computed torque, operational
    // space) or for any kind (-1: closed_loop_derivatives reads data and dd whatever the source): a run of a PD or
    // a table makes only the (nv,) vectors
    explicit SourceWorkspace(const Model& model, int kind = -1);
};

// tau (nv) = the source's torques at (t, q, v).  The computed torque and the operational-space controller read the
// passive torques' parameters (they subtract what the simulator adds) and gravity from ps.
void source_torques(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws, double t,
                    const double* q, const double* v, double* tau);

}  // namespace core::control
