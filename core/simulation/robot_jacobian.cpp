// The Jacobian df/dz of the robot's right-hand side (robot_problem.hpp), assembled from the derivatives of its parts
// rather than by differencing the whole (the C++ side of dynamics/simulation/jacobian.py, whose order of operations
// it follows): Radau's Newton matrix and the variational equations (sensitivities.hpp) use it.
//
// With z = [delta, v, W_source, W_passive] and f = [c(delta, v), a, v . tau_s, v . tau_p] (c: the chart rate of v at
// q = retract(base, delta), configuration.hpp; a: the ABA's accelerations under tau = tau_s + tau_p):
//
//     dc/d delta  central differences of the chart rate alone (no dynamics; zero for 1-dof joints)
//     dc/dv       = c(delta, e_k) column by column (c is linear in v)
//     da/d delta  = (da/dq + M^-1 dtau/dq) T,   T = d(tangent at q)/d delta (identity for 1-dof joints)
//     da/dv       = da/dv + M^-1 dtau/dv
//     d(v . tau)/dz = v^T dtau/dz (+ tau in the v columns)
//
// da/dq (tangent space, Pinocchio's convention), da/dv and M^-1 from aba_derivatives (Carpentier & Mansard 2018);
// dtau_p/dq, dtau_p/dv (diagonal) from passive_derivatives; the source's analytically where control/derivatives.hpp
// has it (then times T), else by central differences of the source alone in the chart coordinates (Python
// callables; the operational space on a model with multi-dof joints).  T from T^-1 = d delta/d e, central differences of the chart's
// inverse along integrate.  The W columns are zero (f does not depend on the quadratures).
//
// Contact: after an evaluation that found a contact (since the last Jacobian), tau also holds the generalised contact
// force tau_c, and its derivatives enter as the source's do (da/d delta += M^-1 dtau_c/d delta, da/dv += M^-1
// dtau_c/dv) with the contact power's row d(v . tau_c)/dz.  d tau_c/dv is analytical and exact
// (contact/force_derivatives.hpp); d tau_c/d delta its stiffness part for Radau's Newton matrix, or, in a run with
// sensitivities (which need it exact), central differences of the contact force alone.  A robot touching nothing
// skips them.
#include <algorithm>
#include <cmath>

#include "aba_derivatives.hpp"
#include "aba.hpp"
#include "crba.hpp"
#include "configuration.hpp"
#include "control/derivatives.hpp"
#include "control/passive.hpp"
#include "linalg.hpp"
#include "robot_problem.hpp"

namespace core::sim {

namespace {
constexpr double FD_STEP = 6e-6;  // central differences (relative, ~ eps^(1/3)), as jacobian.py's
}

void RobotProblem::JacobianWork::reset(const Model& model) {
    const size_t nv = model.nv, nn = nv * nv;
    dd.resize(model);
    for (auto* x : {&da_dq, &da_dv, &Minv, &dts_dd, &dts_dv}) x->assign(nn, 0.0);  // (as made new: zeros)
    for (auto* x : {&dtp_dq, &dtp_dv, &tau_p, &e, &dt, &vt, &tp, &tm, &cp, &cm, &row, &sub}) x->assign(nv, 0.0);
    q.assign(model.nq, 0.0), qt.assign(model.nq, 0.0);
    tq.assign(model.nq, std::nan("")), tbase.assign(model.nq, std::nan(""));  // (no chart blocks yet)
    piv.assign(nv, 0);
    nz_rows.assign(2 * nv, 0), nz_values.assign(2 * nv, 0.0);
    size_t blocks = 0;
    for (int i = 0; i < model.nb; ++i)
        if (model.nv_j[i] > 1) blocks += static_cast<size_t>(model.nv_j[i]) * model.nv_j[i];
    Tb.assign(blocks, 0.0);
}

RobotProblem::ImplicitWork::ImplicitWork(const Model& model, const control::Source& source)
    : pq(model.nv), pv(model.nv), b(model.nv), lam(model.nv),
      on_path(static_cast<size_t>(model.nv) * model.nv, 0) {
    const int nv = model.nv;
    dof_parents(model, lam.data());
    pd_diagonal = source.kind == control::PD;  // no position gain on a joint of several coordinates
    for (int i = 0; i < model.nb && pd_diagonal; ++i)
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i] && model.nv_j[i] > 1; ++k)
            pd_diagonal = pd_diagonal && source.gains[k] == 0.0;
    if (source.kind == control::PD && !pd_diagonal) sq.resize(on_path.size()), sv.resize(on_path.size());
    for (int k = 0; k < nv; ++k) {
        on_path[k * nv + k] = 1;
        for (int j = lam[k]; j >= 0; j = lam[j]) on_path[k * nv + j] = on_path[j * nv + k] = 1;
    }
}

RobotProblem::ContactWork::ContactWork(const Model& model)
    : tau_c(model.nv), dtc_dd(static_cast<size_t>(model.nv) * model.nv), dtc_dv(dtc_dd.size()) {}

// tau_c = the generalised contact force at (q, v) (zeroed first); returns its power.
double RobotProblem::contact_at(const double* q, const double* v, double* tau_c) {
    std::fill(tau_c, tau_c + nv_, 0.0);
    return contact_->torques(model_, q, v, tau_c, nullptr);
}

// If an evaluation since the last Jacobian touched something: tau_c at (delta, v), d tau_c/dv and d tau_c/d delta
// (the stiffness part, or differenced when the run needs it exact).  Otherwise all zero.
void RobotProblem::contact_terms(const double* delta, const double* v) {
    ContactWork& c = *cw_;
    std::fill(c.tau_c.begin(), c.tau_c.end(), 0.0);
    std::fill(c.dtc_dd.begin(), c.dtc_dd.end(), 0.0);
    std::fill(c.dtc_dv.begin(), c.dtc_dv.end(), 0.0);
    if (!contact_->touched()) return;
    JacobianWork& w = *jw_;
    const int nv = nv_;
    double* q = w.q.data();  // (not qt: tangent_to_chart's scratch)
    retract(model_, base_.data(), delta, q);
    if (contact_->jacobian(model_, q, v, c.dtc_dd.data(), c.dtc_dv.data())) {  // exact d tau_c/d delta: differenced
        std::copy(delta, delta + nv, w.dt.begin());
        for (int k = 0; k < nv; ++k) {
            const double h = FD_STEP * std::max(1.0, std::abs(delta[k]));
            w.dt[k] = delta[k] + h;
            retract(model_, base_.data(), w.dt.data(), q);
            contact_at(q, v, w.tp.data());
            w.dt[k] = delta[k] - h;
            retract(model_, base_.data(), w.dt.data(), q);
            contact_at(q, v, w.tm.data());
            w.dt[k] = delta[k];
            for (int r = 0; r < nv; ++r) c.dtc_dd[r * nv + k] = (w.tp[r] - w.tm[r]) / (2 * h);
        }
        retract(model_, base_.data(), delta, q);
    } else if (model_.nq != nv) {
        tangent_to_chart(q, c.dtc_dd.data());
    }
    contact_at(q, v, c.tau_c.data());
    contact_->touched();  // forget the differences' own contacts
}

// A (nv x nv, tangent columns at q) <- A T, T = d(tangent)/d delta.  T is block-diagonal (a joint's tangent moves
// its own chart coordinates only) and the identity on 1-dof joints: only the columns of the joints of several
// coordinates change, X T_j^-1 = A_j solved as T_j^-T X^T = A_j^T one row of A at a time (chart_blocks: T_j^-1).
void RobotProblem::tangent_to_chart(const double* q, double* A) {
    JacobianWork& w = *jw_;
    const int nv = nv_, nq = model_.nq;
    if (!std::equal(q, q + nq, w.tq.begin()) || !std::equal(base_.begin(), base_.end(), w.tbase.begin())) {
        chart_blocks(q);
        std::copy(q, q + nq, w.tq.begin()), std::copy(base_.begin(), base_.end(), w.tbase.begin());
    }
    size_t off = 0;
    for (int i = 0; i < model_.nb; ++i) {
        const int k0 = model_.v_idx[i], m = model_.nv_j[i];
        if (m < 2) continue;
        for (int r = 0; r < nv; ++r) {
            std::copy(A + r * nv + k0, A + r * nv + k0 + m, w.row.begin());
            lu_solve(w.Tb.data() + off, m, w.piv.data() + k0, w.row.data());
            std::copy(w.row.begin(), w.row.begin() + m, A + r * nv + k0);
        }
        off += static_cast<size_t>(m) * m;
    }
}

// For each joint of several coordinates, T_j^-1 = d delta_j/d e_j at q by central differences of chart_difference
// from base along integrate, stored transposed and factored (w.Tb, w.piv).
void RobotProblem::chart_blocks(const double* q) {
    JacobianWork& w = *jw_;
    size_t off = 0;
    for (int i = 0; i < model_.nb; ++i) {
        const int k0 = model_.v_idx[i], m = model_.nv_j[i];
        if (m < 2) continue;
        double* Ti = w.Tb.data() + off;  // Ti[a, b] = (T^-1)[b, a]
        for (int a = 0; a < m; ++a) {
            w.e[k0 + a] = 1.0;
            integrate(model_, q, w.e.data(), FD_STEP, w.sub.data(), w.qt.data());
            chart_difference(model_, base_.data(), w.qt.data(), w.cp.data());
            integrate(model_, q, w.e.data(), -FD_STEP, w.sub.data(), w.qt.data());
            chart_difference(model_, base_.data(), w.qt.data(), w.cm.data());
            w.e[k0 + a] = 0.0;
            for (int b = 0; b < m; ++b) Ti[a * m + b] = (w.cp[k0 + b] - w.cm[k0 + b]) / (2 * FD_STEP);
        }
        lu_factor(Ti, m, w.piv.data() + k0);
        off += static_cast<size_t>(m) * m;
    }
}

// dd = d tau_s/d delta (chart coordinates), dv = d tau_s/dv by central differences of the source alone.
void RobotProblem::source_differences(double t, const double* delta, const double* v, double* dd, double* dv) {
    JacobianWork& w = *jw_;
    const int nv = nv_;
    double *q = w.qt.data(), *tp = w.tp.data(), *tm = w.tm.data();
    std::copy(delta, delta + nv, w.dt.begin());
    std::copy(v, v + nv, w.vt.begin());
    for (int k = 0; k < nv; ++k) {
        const double h = FD_STEP * std::max(1.0, std::abs(delta[k]));
        w.dt[k] = delta[k] + h;
        retract(model_, base_.data(), w.dt.data(), q);
        control::source_torques(model_, source_, passive_, ws_source_, t, q, v, tp);
        w.dt[k] = delta[k] - h;
        retract(model_, base_.data(), w.dt.data(), q);
        control::source_torques(model_, source_, passive_, ws_source_, t, q, v, tm);
        w.dt[k] = delta[k];
        for (int r = 0; r < nv; ++r) dd[r * nv + k] = (tp[r] - tm[r]) / (2 * h);
    }
    retract(model_, base_.data(), delta, q);
    for (int k = 0; k < nv; ++k) {
        const double h = FD_STEP * std::max(1.0, std::abs(v[k]));
        w.vt[k] = v[k] + h;
        control::source_torques(model_, source_, passive_, ws_source_, t, q, w.vt.data(), tp);
        w.vt[k] = v[k] - h;
        control::source_torques(model_, source_, passive_, ws_source_, t, q, w.vt.data(), tm);
        w.vt[k] = v[k];
        for (int r = 0; r < nv; ++r) dv[r * nv + k] = (tp[r] - tm[r]) / (2 * h);
    }
}

// dd = d tau_s/d delta (chart coordinates), dv = d tau_s/dv at q = retract(base, delta): analytical where the kind has it (tangent columns,
// then times T), else differenced.
void RobotProblem::source_derivatives_chart(double t, const double* q, const double* delta, const double* v,
                                            double* dd, double* dv) {
    if (control::source_derivatives(model_, source_, passive_, ws_source_, t, q, v, dd, dv)) {
        if (model_.nq != nv_) tangent_to_chart(q, dd);
        return;
    }
    source_differences(t, delta, v, dd, dv);
}

// Rows 0..nv of the n x n J: dc/d delta (central differences) and dc/dv (c linear in v).
void RobotProblem::chart_derivatives(const double* q, const double* delta, const double* v, double* J, int n) {
    JacobianWork& w = *jw_;
    const int nv = nv_;
    for (int k = 0; k < nv; ++k) {
        w.e[k] = 1.0;
        chart_rate(model_, q, delta, w.e.data(), w.cp.data());
        w.e[k] = 0.0;
        for (int r = 0; r < nv; ++r) J[r * n + nv + k] = w.cp[r];
    }
    if (model_.nq == nv) {  // 1-dof joints only: c = v
        for (int r = 0; r < nv; ++r) std::fill(J + r * n, J + r * n + nv, 0.0);
        return;
    }
    std::copy(delta, delta + nv, w.dt.begin());
    for (int k = 0; k < nv; ++k) {
        const double h = FD_STEP;
        w.dt[k] = delta[k] + h;
        retract(model_, base_.data(), w.dt.data(), w.qt.data());
        chart_rate(model_, w.qt.data(), w.dt.data(), v, w.cp.data());
        w.dt[k] = delta[k] - h;
        retract(model_, base_.data(), w.dt.data(), w.qt.data());
        chart_rate(model_, w.qt.data(), w.dt.data(), v, w.cm.data());
        w.dt[k] = delta[k];
        for (int r = 0; r < nv; ++r) J[r * n + k] = (w.cp[r] - w.cm[r]) / (2 * h);
    }
}

namespace {
// J's row of a power v . tau: d/d delta = v^T dtau/d delta, d/dv = tau + v^T dtau/dv (dd, dv: nv x nv row-major).
void power_row(int nv, const double* v, const double* tau, const double* dd, const double* dv, double* Jr) {
    for (int k = 0; k < nv; ++k) {
        double pd = 0.0, pv = tau[k];
        for (int m = 0; m < nv; ++m) {
            pd += v[m] * dd[m * nv + k];
            pv += v[m] * dv[m * nv + k];
        }
        Jr[k] = pd;
        Jr[nv + k] = pv;
    }
}

// The nonzeros of column k of A (+ B when not null), nv x nv row-major: their rows and values; returns how many.
int column_nonzeros(const double* A, const double* B, int nv, int k, int* rows, double* values) {
    int cnt = 0;
    for (int m = 0; m < nv; ++m) {
        const double x = B ? A[m * nv + k] + B[m * nv + k] : A[m * nv + k];
        if (x != 0.0) rows[cnt] = m, values[cnt++] = x;
    }
    return cnt;
}
}  // namespace

// J's acceleration rows: da/d delta = da/dq + M^-1 (dtau_s + dtau_c)/d delta + M^-1 dtau_p/dq, and the same in v
// (dtc_dd, dtc_dv null without contact: no zeros are added, so the sums keep the bits of a problem that never had
// any); NaN rows when M is singular (as the right-hand side's accelerations: the step is rejected).  The products
// with M^-1 run over the torques' derivatives' nonzeros only (a PD's are diagonal: nv^2 products, not nv^3); a
// zero's product would add an exact zero to the same sum.
void RobotProblem::acceleration_rows(double* J, int n, bool singular, const double* dtc_dd, const double* dtc_dv) {
    JacobianWork& w = *jw_;
    const int nv = nv_;
    const double* Minv = w.Minv.data();
    int *rd = w.nz_rows.data(), *rv = rd + nv;
    double *xd = w.nz_values.data(), *xv = xd + nv;
    for (int k = 0; k < nv; ++k) {
        const int cd = column_nonzeros(w.dts_dd.data(), dtc_dd, nv, k, rd, xd);
        const int cv = column_nonzeros(w.dts_dv.data(), dtc_dv, nv, k, rv, xv);
        for (int r = 0; r < nv; ++r) {
            const double* Mr = Minv + r * nv;
            double sd = 0.0, sv = 0.0;
            for (int i = 0; i < cd; ++i) sd += Mr[rd[i]] * xd[i];
            for (int i = 0; i < cv; ++i) sv += Mr[rv[i]] * xv[i];
            J[(nv + r) * n + k] = w.da_dq[r * nv + k] + sd + Mr[k] * w.dtp_dq[k];
            J[(nv + r) * n + nv + k] = w.da_dv[r * nv + k] + sv + Mr[k] * w.dtp_dv[k];
        }
    }
    if (singular)
        for (int r = nv; r < 2 * nv; ++r) std::fill(J + r * n, J + r * n + 2 * nv, std::nan(""));
}

// J = df/dz at (t, z) (the top comment's table, block by block; f0, mag and ne unused: the whole matrix is written).
bool RobotProblem::jacobian(double t, const double* z, const double*, const double*, int, double* J, Stats& st) {
    if (!jw_) jw_ = from_pool<JacobianWork>(), jw_->reset(model_);
    if (contact_ && !cw_) cw_ = std::make_unique<ContactWork>(model_);
    JacobianWork& w = *jw_;
    const int nv = nv_, n = 2 * nv + nquad_;
    const double *delta = z, *v = z + nv;
    if (contact_) contact_terms(delta, v);
    const double* tau_c = contact_ ? cw_->tau_c.data() : nullptr;
    double* q = w.q.data();
    retract(model_, base_.data(), delta, q);
    source_at(t, q, v, tau_s_.data());
    control::passive_torques(passive_, q, v, nv, w.tau_p.data());
    for (int k = 0; k < nv; ++k)  // tau = passive + source (+ contact)
        tau_p_[k] = w.tau_p[k] + (tau_c ? tau_s_[k] + tau_c[k] : tau_s_[k]);
    const int singular = aba_derivatives(model_, data_, w.dd, q, v, tau_p_.data(), passive_.gravity, nullptr,
                                         w.da_dq.data(), w.da_dv.data(), w.Minv.data());
    source_derivatives_chart(t, q, delta, v, w.dts_dd.data(), w.dts_dv.data());
    control::passive_derivatives(passive_, q, v, nv, w.dtp_dq.data(), w.dtp_dv.data());
    if (model_.nq != nv) tangent_to_chart(q, w.da_dq.data());
    chart_derivatives(q, delta, v, J, n);
    acceleration_rows(J, n, singular >= 0, contact_ ? cw_->dtc_dd.data() : nullptr,
                      contact_ ? cw_->dtc_dv.data() : nullptr);
    power_row(nv, v, tau_s_.data(), w.dts_dd.data(), w.dts_dv.data(), J + 2 * nv * n);  // v . tau_s
    for (int k = 0; k < nv; ++k) {  // v . tau_p (its derivatives are diagonal)
        J[(2 * nv + 1) * n + k] = v[k] * w.dtp_dq[k];
        J[(2 * nv + 1) * n + nv + k] = w.tau_p[k] + v[k] * w.dtp_dv[k];
    }
    for (int r = 0; r < n; ++r) std::fill(J + r * n + 2 * nv, J + (r + 1) * n, 0.0);
    if (contact_)  // v . tau_c (zero while nothing touches)
        power_row(nv, v, tau_c, cw_->dtc_dd.data(), cw_->dtc_dv.data(), J + (2 * nv + 2) * n);
    abort_if_failed();
    st.jacobian_evals += 1;
    return true;
}

// The linearly implicit Euler's terms at (t, z) (implicit_euler.cpp), in tangent coordinates at q = retract(base,
// delta) (z's delta is zero at a step's start: the chart's coordinates are the tangent's there).
//     r = tau_s + tau_p - RNEA(q, v, 0, f_c)          (= M a: the ABA's first pass and the contact's forces as
//                                                        the right-hand side has them, then aba_bias_pass)
// D = d tau/dv and K = d tau/dq sum the contact's (d tau_c/dq its stiffness part, as radau's), the passive torques'
// and a PD source's.  lam when D and K keep to the paths to the root (a contact between two of the robot's
// branches does not): then M's, D's and K's entries off them are not written.
bool RobotProblem::implicit_terms(double t, const double* z, double* r, double* w, double* M, double* D, double* K,
                                  const int*& lam) {
    if (!iw_) iw_ = std::make_unique<ImplicitWork>(model_, source_);
    ImplicitWork& iw = *iw_;
    const int nv = nv_;
    const size_t n2 = static_cast<size_t>(nv) * nv;
    const double* v = z + nv;
    double* q = qbuf_.data();
    retract(model_, base_.data(), z, q);
    double power_s, power_p, power_c = 0.0;
    source_and_passive(t, q, v, power_s, power_p);  // tau_p_ = source + passive
    aba_rigid_body_pass(model_, data_, q, v, nullptr, true);
    if (contact_) power_c = contact_->bias(model_, data_, q, v, z);
    aba_bias_pass(model_, data_, passive_.gravity, iw.b.data());
    for (int k = 0; k < nv; ++k) r[k] = tau_p_[k] - iw.b[k];
    const bool touching = contact_ && contact_->touched();
    quadratures(w, power_s, power_p, power_c);
    if (touching) {
        contact_->jacobian(model_, q, v, K, D);  // (at the q just evaluated: its contacts again, not found again)
    } else {
        std::fill(D, D + n2, 0.0), std::fill(K, K + n2, 0.0);
    }
    if (source_.kind == control::PD && iw.pd_diagonal) {  // d tau/dq = -kp, d tau/dv = -kd (pd_derivatives')
        const double *kp = source_.gains.data(), *kd = kp + nv;
        for (int k = 0; k < nv; ++k) K[k * (nv + 1)] -= kp[k], D[k * (nv + 1)] -= kd[k];
    } else if (source_.kind == control::PD) {
        control::source_derivatives(model_, source_, passive_, ws_source_, t, q, v, iw.sq.data(), iw.sv.data());
        for (size_t k = 0; k < n2; ++k) K[k] += iw.sq[k], D[k] += iw.sv[k];
    }
    control::passive_derivatives(passive_, q, v, nv, iw.pq.data(), iw.pv.data());
    for (int k = 0; k < nv; ++k) K[k * (nv + 1)] += iw.pq[k], D[k * (nv + 1)] += iw.pv[k];
    lam = iw.lam.data();
    for (size_t k = 0; k < n2; ++k)
        if (!iw.on_path[k] && (D[k] != 0.0 || K[k] != 0.0)) {
            lam = nullptr;
            std::fill(M, M + n2, 0.0);
            break;
        }
    crba_from_placements(model_, data_, M);  // (data_.X: the first pass's, at this q)
    return true;
}

}  // namespace core::sim
