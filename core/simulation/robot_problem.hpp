// The robot as an ODE for the solvers: the state, the right-hand side, and what is kept per sample (the C++ side
// of dynamics/simulation/problem.py).
//
// The equations of motion (Featherstone 2008, eq. 1.1, solved by the ABA):
//     M(q) v' + C(q, v) v + g(q) = tau_source(t, q, v) + tau_passive(q, v) (+ J_c^T f_c),   q' = v (on the manifold)
// The integrated state is z = [delta (nv), v (nv), W_source, W_passive (, W_contact)]: delta is the chart coordinate
// of q around `base`, the configuration at the start of the current step (configuration.hpp; re-centred after every
// step by rebase so quaternions stay unit length), and the quadratures integrate the power of the source, of the
// passive torques and, with contact, of the contact forces, for the energy balance.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "control/sources.hpp"
#include "data.hpp"
#include "derivatives_data.hpp"
#include "solver.hpp"
#include "workspace_pool.hpp"

namespace core::sim {

// What a run writes per sample, into arrays its caller owns (numpy's, from the bindings); an output with zero rows
// is neither kept nor, for the torques, computed.
struct Outputs {
    double* t = nullptr;  // (T,) sample times (given: where to sample; rewritten with the time reached)
    int64_t T = 0;
    double *q = nullptr, *v = nullptr, *tau = nullptr;  // (T or 0, nq / nv / nv)
    bool keep_q = false, keep_v = false, keep_tau = false;
    double* w = nullptr;  // (T, nquad): the work of the source, the passive torques (and the contact)
    double* e = nullptr;  // (T, 2): kinetic and potential energy (the report's energy balance), or null: none
    int64_t* count = nullptr;  // (1,): samples written, read by the progress bar while the run goes
};

// Contact in the right-hand side: the hooks a contact model gives the simulation (contact/ implements them).
class ContactHooks {
public:
    virtual ~ContactHooks() = default;
    // After the ABA's first pass (data.X, data.v): the contact forces subtracted from data.pA as external body
    // forces; returns their power.  delta: the chart coordinates of q (the clearance's bound follows them).
    virtual double bias(const Model& model, Data& data, const double* q, const double* v, const double* delta) = 0;
    // tau += J_c^T f_c at (q, v); returns the power (the constrained right-hand side's way in).  delta: null where q
    // is not on the step's chart (never skipped).
    virtual double torques(const Model& model, const double* q, const double* v, double* tau, const double* delta) = 0;
    virtual void emit(int64_t j, const double* q, const double* v) = 0;      // the active contacts of sample j
    virtual void track(double t, const double* base, const double* v, const double* delta) = 0;  // after a step
    virtual void rebased() {}                                                // a projection moved the base
    // the state was set from outside (a simulator's reset): also forget the episode of contact (touchdown's)
    virtual void restart() { rebased(); }
    virtual bool touchdown() = 0;  // the last accepted state touches something after touching nothing (once)
    virtual bool touched() = 0;    // an evaluation found a contact since the last call (the Jacobian's test)
    virtual bool touching() const = 0;  // the last accepted state touches something
    // dv = d tau_c/dv, dq = the stiffness part of d tau_c/dq at (q, v) (nv x nv, tangent space); returns whether the
    // run needs d tau_c/dq exact (then the caller differences it: a run with sensitivities).
    virtual bool jacobian(const Model& model, const double* q, const double* v, double* dq, double* dv) = 0;
};

class RobotProblem : public Problem {
public:
    RobotProblem(const Model& model, const control::Passive& passive, control::Source& source, const double* q0,
                 const Outputs& out, ContactHooks* contact);
    void rhs(double t, const double* z, double* dz) override;
    void rebase(double t, double* z, double* dz, double* mag) override;
    void euler_config(double* z, double h) override;
    void emit(int64_t j, double t, const double* z) override;
    bool touchdown() override { return contact_ && contact_->touchdown(); }
    bool touching() const override { return contact_ && contact_->touching(); }
    // J = df/dz assembled from the parts' derivatives (robot_jacobian.cpp).
    bool jacobian(double t, const double* z, const double* f0, const double* mag, int ne, double* J,
                  Stats& st) override;
    // The linearly implicit Euler's terms (robot_jacobian.cpp): r by the RNEA, M by the CRBA; D, K from the contact
    // (when it touches something), the passive torques and a PD source (the other sources stay explicit: their
    // derivatives cost more than the step).
    bool implicit_terms(double t, const double* z, double* r, double* w, double* M, double* D, double* K,
                        const int*& lam) override;
    bool aborted() const override { return aborted_; }
    const std::vector<int>* second_order_blocks() const override { return &blocks_; }
    // A torque held constant over a control period of the caller's loop (core/simulation/simulator.hpp), added to
    // the source's; null: none (a simulate run).
    void hold(const double* tau) { held_ = tau; }
    // The state was moved from outside (a simulator's reset, or its return to a period's start): the contact's
    // clearance and a Python torque's failure are forgotten.
    void restart() {
        aborted_ = false;
        if (contact_) contact_->restart();
    }

    const Model& model() const { return model_; }
    const double* base() const { return base_.data(); }
    double* base() { return base_.data(); }
    control::Source& source() { return source_; }
    const control::Passive& passive() const { return passive_; }
    const Outputs& outputs() const { return out_; }
    int nquad() const { return nquad_; }

protected:
    // tau = the source's torques at (t, q, v), plus the held torque.
    void source_at(double t, const double* q, const double* v, double* tau);
    // qbuf = the configuration of z around base; dz's chart part = the chart rate of v.  Returns q.
    const double* chart_and_velocity(const double* z, double* dz);
    // tau_p = source + passive torques at (t, q, v) (tau_s the source's); the powers through power_s, power_p.
    void source_and_passive(double t, const double* q, const double* v, double& power_s, double& power_p);
    void quadratures(double* dz, double power_s, double power_p, double power_c) const;
    void abort_if_failed();

    // The Jacobian's pieces (robot_jacobian.cpp) and its workspace, taken from the thread's pool at the first
    // Jacobian (the explicit methods' only one is the stability probe): nv x nv row-major matrices and nv (or nq)
    // vectors.
    struct JacobianWork {
        DerivativesData dd;
        std::vector<double> da_dq, da_dv, Minv, dts_dd, dts_dv;  // nv x nv
        std::vector<double> dtp_dq, dtp_dv, tau_p, e, dt, vt, tp, tm, cp, cm, row, sub;  // nv
        std::vector<double> q, qt, tq, tbase;  // nq (tq, tbase: the q and base of Tb)
        std::vector<double> Tb;  // the transposed T_j^-1 of the joints of several coordinates, factored (packed)
        std::vector<int> piv;                                                           // nv
        std::vector<int> nz_rows;       // 2 nv: a column's nonzeros of the torques' derivatives (acceleration_rows)
        std::vector<double> nz_values;  // 2 nv
        void reset(const Model& model);  // sized for model, its cache of Tb emptied (capacity kept)
    };
    // The contact's part (robot_jacobian.cpp): tau_c and its derivatives in the chart coordinates.
    struct ContactWork {
        std::vector<double> tau_c, dtc_dd, dtc_dv;  // nv, nv x nv, nv x nv
        explicit ContactWork(const Model& model);
    };
    // The implicit Euler's scratch: a PD source's derivatives (nv x nv, when not diagonal), the passive's
    // (diagonal), the bias torques (nv); Featherstone's lambda (nv) and whether each pair of coordinates lies on one
    // path to the root (nv x nv); whether a PD source's derivatives are its gains on the diagonal (no position gain
    // on a multi-dof joint).
    struct ImplicitWork {
        std::vector<double> sq, sv, pq, pv, b;
        std::vector<int> lam;
        std::vector<char> on_path;
        bool pd_diagonal = false;
        ImplicitWork(const Model& model, const control::Source& source);
    };
    double contact_at(const double* q, const double* v, double* tau_c);
    void acceleration_rows(double* J, int n, bool singular, const double* dtc_dd, const double* dtc_dv);
    void contact_terms(const double* delta, const double* v);
    void source_derivatives_chart(double t, const double* q, const double* delta, const double* v, double* dd,
                                  double* dv);
    void source_differences(double t, const double* delta, const double* v, double* dd, double* dv);
    void chart_derivatives(const double* q, const double* delta, const double* v, double* J, int n);
    void tangent_to_chart(const double* q, double* A);
    void chart_blocks(const double* q);

    const Model& model_;
    const control::Passive& passive_;
    control::Source& source_;
    control::SourceWorkspace ws_source_;
    ContactHooks* contact_;
    Outputs out_;
    int nv_, nquad_;
    std::vector<double> base_, qbuf_, tau_s_, tau_p_;
    std::vector<int> blocks_;  // the first velocity coordinate of each joint, then nv
    Pooled<Data> pooled_data_;  // the ABA's workspace, from the thread's pool
    Data& data_;
    Pooled<JacobianWork> jw_;
    std::unique_ptr<ContactWork> cw_;
    std::unique_ptr<ImplicitWork> iw_;
    bool aborted_ = false;
    const double* held_ = nullptr;
};

}  // namespace core::sim
