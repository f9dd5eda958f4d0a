// The operational-space controller's state derivatives (operational_space_derivatives.hpp has the equations).
#include "operational_space_derivatives.hpp"

#include <cmath>
#include <vector>

#include "derivatives.hpp"
#include "operational_space.hpp"
#include "rnea_derivatives.hpp"

namespace core::control {

namespace {

// Column m of the (6 x nv) row-major matrix A: its linear (rows 0-2) and angular (rows 3-5) halves.
Vec3 linear_column(const double* A, int nv, int m) { return {A[m], A[nv + m], A[2 * nv + m]}; }
void set_column(double* A, int nv, int m, const Vec3& lin, const Vec3& ang) {
    A[m] = lin.x, A[nv + m] = lin.y, A[2 * nv + m] = lin.z;
    A[3 * nv + m] = ang.x, A[4 * nv + m] = ang.y, A[5 * nv + m] = ang.z;
}

// S[j] = (w_j, v_j): joint j's axis in the world frame at the world origin, from J at the frame origin p
// (v_j = J^v_j - w_j x p = J^v_j + p x w_j).
void world_axes(const double* J, int nv, const Vec3& p, std::vector<Motion>& S) {
    for (int j = 0; j < nv; ++j) {
        const Vec3 w = {J[3 * nv + j], J[4 * nv + j], J[5 * nv + j]};
        const Vec3 vo = cross(p, w);
        S[j] = {w, {J[j] + vo.x, J[nv + j] + vo.y, J[2 * nv + j] + vo.z}};
    }
}

// pre[m] = sum_{j < m} u_j S_j, suf[m] = sum_{j >= m} u_j S_j.
void partial_sums(const std::vector<Motion>& S, const double* u, int nv, std::vector<Motion>& pre,
                  std::vector<Motion>& suf) {
    Motion acc;
    for (int m = 0; m < nv; ++m) {
        pre[m] = acc;
        acc = acc + u[m] * S[m];
    }
    acc = Motion{};
    for (int m = nv - 1; m >= 0; --m) {
        acc = acc + u[m] * S[m];
        suf[m] = acc;
    }
}

// out (6 x nv): column m = (dJ/dq_m) u, J at p in world axes.
void jacobian_derivative_times(const std::vector<Motion>& S, const double* J, int nv, const Vec3& p, const double* u,
                               std::vector<Motion>& pre, std::vector<Motion>& suf, double* out) {
    partial_sums(S, u, nv, pre, suf);
    const Vec3 wu = suf[0].w;  // sum_j w_j u_j
    for (int m = 0; m < nv; ++m) {
        const Motion d = cross(S[m], suf[m]);
        const Vec3 lin = (d.v + cross(d.w, p)) + cross(wu, linear_column(J, nv, m));
        set_column(out, nv, m, lin, d.w);
    }
}

// G[j, m] = sum_a F_a dJ[rows[a], j]/dq_m: d(J^T F)/dq at fixed F.
void jacobian_transpose_derivative(const std::vector<Motion>& S, const double* J, int nv, const Vec3& p,
                                   const Source& src, const double* F, double* G) {
    double f[6] = {};
    for (size_t a = 0; a < src.rows.size(); ++a) f[src.rows[a]] += F[a];
    const Vec3 flin = {f[0], f[1], f[2]}, fang = {f[3], f[4], f[5]};
    const Vec3 n_o = fang + cross(p, flin);  // the task force's moment at the world origin
    for (int j = 0; j < nv; ++j)
        for (int m = 0; m < nv; ++m) {
            const Vec3 c = cross(S[j].w, linear_column(J, nv, m));
            double x = flin.x * c.x + flin.y * c.y + flin.z * c.z;
            if (m <= j) {
                const Motion d = cross(S[m], S[j]);
                x += d.w.x * n_o.x + d.w.y * n_o.y + d.w.z * n_o.z + d.v.x * flin.x + d.v.y * flin.y + d.v.z * flin.z;
            }
            G[j * nv + m] = x;
        }
}

// Bq = d(Jdot v)/dq, Bv = d(Jdot v)/dv (6 x nv), Jdot v the frame's classical acceleration at a = 0 at p.
void bias_derivatives(const std::vector<Motion>& S, const double* J, int nv, const Vec3& p, const double* v,
                      std::vector<Motion>& pre, std::vector<Motion>& suf, std::vector<Motion>& T, double* Bq,
                      double* Bv) {
    partial_sums(S, v, nv, pre, suf);
    Motion acc;
    for (int m = nv - 1; m >= 0; --m) {  // T_m = sum_{k >= m} v_k S_k x V_{>k}
        const Motion c = cross(S[m], m + 1 < nv ? suf[m + 1] : Motion{});
        acc = acc + v[m] * c;
        T[m] = acc;
    }
    const Vec3 w = suf[0].w, aw = T[0].w;
    const Vec3 vp = suf[0].v + cross(w, p);
    for (int m = 0; m < nv; ++m) {
        const Vec3 dp = linear_column(J, nv, m);
        const Motion &up = suf[m], &lo = pre[m];
        const Motion dV = cross(S[m], up);  // dV/dq_m
        const Vec3 dvp = (dV.v + cross(dV.w, p)) + cross(w, dp);
        const Motion t1 = cross(S[m], T[m]), t2 = cross(lo, dV);
        const Vec3 dAw = t1.w + t2.w, dAv = t1.v + t2.v;
        const Vec3 lin_q = ((dAv + cross(dAw, p)) + cross(aw, dp)) + (cross(dV.w, vp) + cross(w, dvp));
        set_column(Bq, nv, m, lin_q, dAw);
        const Motion e = cross(S[m], up - lo);
        const Vec3 lin_v = (e.v + cross(e.w, p)) + (cross(S[m].w, vp) + cross(w, dp));
        set_column(Bv, nv, m, lin_v, e.w);
    }
}

// Rows 3-5 of De (6 x nv, zero there on entry) = d e_o/dq = -Jr(e_o)^-1 w_m, e_o = log(R_d R^T).
void orientation_rows(const Source& src, double t, const Mat3& R, const double* J, int nv, double* De) {
    Mat3 Rd;
    Vec3 wd;
    orientation_at(src, t, Rd, wd);
    const Vec3 e = rotation_log(Rd * transpose(R));
    const double c = so3_jinv_c(e.x, e.y, e.z);
    const double n2 = e.x * e.x + e.y * e.y + e.z * e.z;
    const double P[3][3] = {{0.0, -e.z, e.y}, {e.z, 0.0, -e.x}, {-e.y, e.x, 0.0}};
    for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) {
            const double x = 0.5 * P[r][s] + c * e[r] * e[s] + (r == s ? 1.0 - c * n2 : 0.0);
            for (int m = 0; m < nv; ++m) De[(3 + r) * nv + m] -= x * J[(3 + s) * nv + m];
        }
}

// dq += G + J^T Lambda X - Kp0 - dtau_passive/dq, dv += J^T Lambda Y - Kd0 - dtau_passive/dv (X = dy/dq - dA F,
// Y = dy/dv); (dq, dv) hold the inverse dynamics' derivatives at a = 0.  D: dJ v, dJ s, d(Jdot v)/dq,
// d(Jdot v)/dv, de/dq (6 x nv each).
void assemble(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws, const double* q,
              const double* v, const double* D, const double* G, double* dq, double* dv) {
    const int nv = model.nv, r = static_cast<int>(src.rows.size());
    const size_t n6 = 6 * static_cast<size_t>(nv);
    const double *J = ws.J.data(), *JM = ws.JM.data(), *kp0 = src.gains.data(), *kd0 = src.gains.data() + nv;
    const double (&kt)[2][6] = src.task_gains;
    const double *dJv = D, *dJs = D + n6, *Bq = D + 2 * n6, *Bv = D + 3 * n6, *De = D + 4 * n6;
    std::vector<double> inner(static_cast<size_t>(nv) * nv), X(static_cast<size_t>(r) * nv), Y(X.size());
    for (size_t i = 0; i < inner.size(); ++i) inner[i] = ws.DM[i] - G[i];
    for (int c = 0; c < nv; ++c) inner[c * nv + c] += kp0[c];
    for (int a = 0; a < r; ++a) {
        const int k = src.rows[a];
        for (int m = 0; m < nv; ++m) {
            double x = -kt[1][k] * dJv[k * nv + m] + kt[0][k] * De[k * nv + m] - Bq[k * nv + m] - dJs[k * nv + m];
            for (int c = 0; c < nv; ++c) x += JM[a * nv + c] * inner[c * nv + m];
            X[a * nv + m] = x;
            Y[a * nv + m] = -kt[1][k] * J[k * nv + m] - Bv[k * nv + m] + JM[a * nv + m] * kd0[m];
        }
    }
    for (int c = 0; c < nv; ++c)
        for (int a = 0; a < r; ++a) {
            double g = 0.0;  // (J^T Lambda)[c, a]
            for (int b = 0; b < r; ++b) g += J[src.rows[b] * nv + c] * ws.Lam[6 * b + a];
            for (int m = 0; m < nv; ++m) {
                dq[c * nv + m] += g * X[a * nv + m];
                dv[c * nv + m] += g * Y[a * nv + m];
            }
        }
    passive_derivatives(ps, q, v, nv, ws.pq.data(), ws.pv.data());
    for (int c = 0; c < nv; ++c) {
        for (int m = 0; m < nv; ++m) dq[c * nv + m] += G[c * nv + m];
        dq[c * nv + c] -= kp0[c] + ws.pq[c];
        dv[c * nv + c] -= kd0[c] + ws.pv[c];
    }
}

}  // namespace

bool operational_space_derivatives(const Model& model, const Source& src, const Passive& ps, SourceWorkspace& ws,
                                   double t, const double* q, const double* v, double* dq, double* dv) {
    const int nv = model.nv, r = static_cast<int>(src.rows.size());
    if (model.nq != nv) return false;
    const size_t nn = static_cast<size_t>(nv) * nv;
    std::vector<double> tau(nv);
    passive_torques(ps, q, v, nv, ws.pas.data());
    const Transform T = operational_space_torques(model, src, ps.gravity, ws, t, q, v, ws.pas.data(), tau.data());
    for (int i = 0; i < nv; ++i)
        if (!std::isfinite(tau[i])) {
            std::fill(dq, dq + nn, std::nan("")), std::fill(dv, dv + nn, std::nan(""));
            return true;
        }
    const double *J = ws.J.data(), *Minv = ws.Minv.data();
    std::vector<double> F(r, 0.0), u(ws.tp), s(nv, 0.0);  // F = Lambda y, u = J^T F + tau_p, s = M^-1 u
    for (int a = 0; a < r; ++a)
        for (int b = 0; b < r; ++b) F[a] += ws.Lam[6 * a + b] * ws.y[b];
    for (int c = 0; c < nv; ++c)
        for (int a = 0; a < r; ++a) u[c] += J[src.rows[a] * nv + c] * F[a];
    for (int c = 0; c < nv; ++c)
        for (int k = 0; k < nv; ++k) s[c] += Minv[c * nv + k] * u[k];
    // the inverse dynamics at a = 0 into (dq, dv), and d(M s)/dq without gravity into DM
    std::vector<double> scratch(nn);
    rnea_derivatives(model, ws.dd, q, v, ws.zero.data(), ps.gravity, nullptr, dq, dv, ws.M.data());
    rnea_derivatives(model, ws.dd, q, ws.zero.data(), s.data(), Vec3{}, nullptr, ws.DM.data(), scratch.data(),
                     ws.M.data());
    // the frame's kinematic derivatives
    std::vector<Motion> S(nv), pre(nv), suf(nv), Tm(nv);
    const size_t n6 = 6 * static_cast<size_t>(nv);
    std::vector<double> D(5 * n6, 0.0), G(nn);  // dJ v, dJ s, d(Jdot v)/dq, d(Jdot v)/dv, de/dq
    world_axes(J, nv, T.p, S);
    jacobian_derivative_times(S, J, nv, T.p, v, pre, suf, D.data());
    jacobian_derivative_times(S, J, nv, T.p, s.data(), pre, suf, D.data() + n6);
    jacobian_transpose_derivative(S, J, nv, T.p, src, F.data(), G.data());
    bias_derivatives(S, J, nv, T.p, v, pre, suf, Tm, D.data() + 2 * n6, D.data() + 3 * n6);
    double* De = D.data() + 4 * n6;
    for (int m = 0; m < nv; ++m) De[m] = -J[m], De[nv + m] = -J[nv + m], De[2 * nv + m] = -J[2 * nv + m];
    orientation_rows(src, t, T.R, J, nv, De);
    assemble(model, src, ps, ws, q, v, D.data(), G.data(), dq, dv);
    return true;
}

}  // namespace core::control
