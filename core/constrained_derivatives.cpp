// Analytical derivatives of constrained forward dynamics (constrained_derivatives.hpp has the equations).
#include "constrained_derivatives.hpp"

#include <algorithm>
#include <cmath>

#include "rnea_derivatives.hpp"

namespace core {

void ConstrainedDerivativesData::resize(const Model& model, const Constraints& con) {
    const size_t nb = model.nb, nv = model.nv, m = con.m;
    rd.resize(model), cd.resize(model, con);
    dq.resize(nv * nv), dv.resize(nv * nv), M.resize(nv * nv), P.resize(nv * nv);
    G.resize(m * nv), H.resize(m * nv), XT.resize(3 * nv * nv), RT.resize(3 * nv * m);
    K.resize(m * m), Kinv.resize(m * m), YT.resize(nv * m), x.resize(m), lam.resize(m), a.resize(nv);
    JJ.resize(m * m), LN.resize(m * m), Gm.resize(m * m), Q.resize(m * m), piv.resize(m);
    s.resize(m), t.resize(m), w.resize(nv), zero.resize(nv);
    anc.assign(nb * nb, 0), owner.resize(nv);
    for (int i = 0; i < model.nb; ++i) {  // the tree's ancestry and each coordinate's body
        const int p = model.parents[i];
        if (p >= 0) std::copy(anc.begin() + p * nb, anc.begin() + (p + 1) * nb, anc.begin() + i * nb);
        anc[i * nb + i] = 1;
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) owner[k] = i;
    }
}

namespace {

Vec3 column(const Mat3& R, int k) { return {R[k], R[3 + k], R[6 + k]}; }

// World axes and origin of anchor s (0: a, 1: b) of constraint c, from the derivatives' forward pass.
Transform anchor_pose(const Constraints& con, const DerivativesData& d, int c, int s) {
    const int b = con.body[2 * c + s];
    const Mat3& R = con.R[2 * c + s];
    const Vec3& p = con.p[2 * c + s];
    if (b < 0) return {R, p};
    const Transform& B = d.oM[b];
    return {B.R * R, rot(B.R, p) + B.p};
}

// The angular part of body b's motion X[b], zero for the world (b = -1).
Vec3 body_w(const std::vector<Motion>& X, int b) { return b < 0 ? Vec3{} : X[b].w; }

// Along coordinate j, for the point x fixed on body b (all zero when j is not on b's support), world axes.
struct PointPartials {
    Vec3 dx, dvel, dacc, dacc_v;  // d x / dq, d vel / dq, d acc / dq, d acc / dv
    Vec3 dw_q, dal_q, dal_v, dw_v;  // the body's angular velocity and acceleration along q_j and v_j
};

PointPartials point_partials(const DerivativesData& d, int b, const Vec3& x, int j, bool inside) {
    if (!inside) return {};
    const Motion &Jj = d.J[j], &dV = d.dV[j], &ov = d.ov[b];
    const Motion& oa = d.oa[b];  // oa carries gravity (0, -g): a uniform field, which leaves every derivative alike
    const Motion c = cross(Jj, ov);
    const Motion dov = dV + c;  // d ov_b / dq_j
    const Motion c1 = cross(dV, ov), c2 = cross(Jj, oa);
    const Motion doa = d.dAq[j] + (c1 + c2);  // d oa_b / dq_j
    const Motion e = d.dAv[j] + c;           // d oa_b / dv_j
    const Vec3 vel = ov.v + cross(ov.w, x);
    const Vec3 dx = Jj.v + cross(Jj.w, x);
    const Vec3 dvel = (dov.v + cross(dov.w, x)) + cross(ov.w, dx);
    const Vec3 dacc = ((doa.v + cross(doa.w, x)) + cross(oa.w, dx)) + (cross(dov.w, vel) + cross(ov.w, dvel));
    const Vec3 dacc_v = (e.v + cross(e.w, x)) + (cross(Jj.w, vel) + cross(ov.w, dx));
    return {dx, dvel, dacc, dacc_v, dov.w, doa.w, e.w, Jj.w};
}

// Jl(e)^-1 y, Jl the left Jacobian of SO(3): y - e x y / 2 + c e x (e x y), c = 1/th^2 - (1 + cos th) /
// (2 th sin th) (-> 1/12 as th -> 0).
Vec3 jl_inverse(const Vec3& e, const Vec3& y) {
    const double th = std::sqrt(dot(e, e));
    const double c = th < 1e-4 ? 1.0 / 12.0 + th * th / 720.0
                               : 1.0 / (th * th) - (1.0 + std::cos(th)) / (2.0 * th * std::sin(th));
    const Vec3 ey = cross(e, y);
    return (y + (-0.5) * ey) + c * cross(e, ey);
}

// The motions of a loop constraint's two anchors that its angular rows read.
struct AnchorPair {
    Mat3 Ra, Rb;
    Vec3 wA, wB, alA, alB;
};

// Column j of the weld's or hinge's angular rows (r + 3 on) of dr2/dq into G and of dr2/dv into H (nv columns).
void angular_rows(int kind, int r, int j, int nv, const AnchorPair& an, const PointPartials& pa,
                  const PointPartials& pb, double acc, double alpha, double beta, double* G, double* H) {
    const Vec3 dwq = pa.dw_q - pb.dw_q, dalq = pa.dal_q - pb.dal_q, dalv = pa.dal_v - pb.dal_v;
    const Vec3 &dA = pa.dw_v, &dB = pb.dw_v;  // J_j^w on each side's support, else zero
    const Vec3 ddw_v = dA - dB;
    if (kind == WELD) {
        const Mat3 R = an.Ra * transpose(an.Rb);
        const Vec3 dphi = jl_inverse(rotation_log(R), dA - rot(R, dB));
        for (int t = 0; t < 3; ++t) {
            G[(r + 3 + t) * nv + j] += acc * dalq[t] + 2.0 * alpha * dwq[t] + beta * beta * dphi[t];
            H[(r + 3 + t) * nv + j] += acc * dalv[t] + 2.0 * alpha * ddw_v[t];
        }
        return;
    }
    const Vec3 uA = column(an.Ra, 2), uB = column(an.Rb, 2);
    const Vec3 n = cross(uB, uA), dn = cross(cross(dB, uB), uA) + cross(uB, cross(dA, uA));
    const Vec3 dw = an.wA - an.wB, dal = an.alA - an.alB;
    for (int s = 0; s < 2; ++s) {
        const Vec3 tk = column(an.Ra, s);
        const Vec3 dt = cross(dA, tk), wt = cross(an.wA, tk);
        G[(r + 3 + s) * nv + j] +=
            acc * (dot(dt, dal) + dot(tk, dalq) + dot(cross(pa.dw_q, tk) + cross(an.wA, dt), dw) + dot(wt, dwq)) +
            2.0 * alpha * (dot(dt, dw) + dot(tk, dwq)) + beta * beta * (dot(dt, n) + dot(tk, dn));
        H[(r + 3 + s) * nv + j] += acc * (dot(tk, dalv) + dot(cross(dA, tk), dw) + dot(wt, ddw_v)) +
                                   2.0 * alpha * dot(tk, ddw_v);
    }
}

// G = dr2/dq and H = dr2/dv (m x nv) at fixed a, from the RNEA derivatives' forward pass; acc = 0 leaves out
// J a + gamma (acc = 0, alpha = 1/2, beta = 0: d(J v)/dq in G).
void row_partials(const Model& model, const Constraints& con, const DerivativesData& d,
                  const ConstrainedDerivativesData& w, double acc, double alpha, double beta, double* G, double* H) {
    const int nv = model.nv, nb = model.nb;
    std::fill(G, G + static_cast<size_t>(con.m) * nv, 0.0), std::fill(H, H + static_cast<size_t>(con.m) * nv, 0.0);
    for (int c = 0; c < con.nc; ++c) {
        const int kind = con.kind[c], r = con.row[c];
        if (kind == COUPLING) {  // q_f - k q_l - offset, linear
            const int vf = con.idx[4 * c + 1], vl = con.idx[4 * c + 3];
            const double k = con.coef[2 * c];
            G[r * nv + vf] += beta * beta;
            G[r * nv + vl] -= beta * beta * k;
            H[r * nv + vf] += 2.0 * alpha;
            H[r * nv + vl] -= 2.0 * alpha * k;
            continue;
        }
        const int ba = con.body[2 * c], bb = con.body[2 * c + 1];
        const Transform Ta = anchor_pose(con, d, c, 0), Tb = anchor_pose(con, d, c, 1);
        const AnchorPair an = {Ta.R, Tb.R, body_w(d.ov, ba), body_w(d.ov, bb), body_w(d.oa, ba), body_w(d.oa, bb)};
        for (int j = 0; j < nv; ++j) {
            const bool ina = ba >= 0 && w.anc[ba * nb + w.owner[j]], inb = bb >= 0 && w.anc[bb * nb + w.owner[j]];
            if (!(ina || inb)) continue;
            const PointPartials pa = point_partials(d, ba, Ta.p, j, ina), pb = point_partials(d, bb, Tb.p, j, inb);
            const Vec3 dx = pa.dx - pb.dx, dvel = pa.dvel - pb.dvel, dacc = pa.dacc - pb.dacc;
            const Vec3 dacc_v = pa.dacc_v - pb.dacc_v;
            for (int t = 0; t < 3; ++t) {
                G[(r + t) * nv + j] += acc * dacc[t] + 2.0 * alpha * dvel[t] + beta * beta * dx[t];
                H[(r + t) * nv + j] += acc * dacc_v[t] + 2.0 * alpha * dx[t];
            }
            if (kind != POINT) angular_rows(kind, r, j, nv, an, pa, pb, acc, alpha, beta, G, H);
        }
    }
}

// P = d(J^T lambda)/dq (nv x nv) at fixed lambda.
void force_partials(const Model& model, const Constraints& con, const DerivativesData& d,
                    const ConstrainedDerivativesData& w, const double* lam, double* P) {
    const int nv = model.nv, nb = model.nb;
    std::fill(P, P + static_cast<size_t>(nv) * nv, 0.0);
    for (int c = 0; c < con.nc; ++c) {
        const int kind = con.kind[c], r = con.row[c];
        if (kind == COUPLING) continue;  // a coupling's J is constant
        const int ba = con.body[2 * c];
        const Mat3 Ra = anchor_pose(con, d, c, 0).R;
        const Vec3 f = {lam[r], lam[r + 1], lam[r + 2]};
        Vec3 tq;
        if (kind == WELD) tq = {lam[r + 3], lam[r + 4], lam[r + 5]};
        else if (kind == REVOLUTE) tq = lam[r + 3] * column(Ra, 0) + lam[r + 4] * column(Ra, 1);
        for (int s = 0; s < 2; ++s) {
            const int b = con.body[2 * c + s];
            if (b < 0) continue;
            const Vec3 x = anchor_pose(con, d, c, s).p;
            const double sign = s == 0 ? 1.0 : -1.0;
            const Force F = {sign * (cross(x, f) + tq), sign * f};
            for (int j = 0; j < nv; ++j) {
                const bool inb = w.anc[b * nb + w.owner[j]];
                const bool ina = kind == REVOLUTE && ba >= 0 && w.anc[ba * nb + w.owner[j]];
                if (!(inb || ina)) continue;  // F does not change along q_j, nor does any J_k of b's support
                const Motion& Jj = d.J[j];
                Vec3 dn = inb ? cross(Jj.v + cross(Jj.w, x), f) : Vec3{};
                if (ina) dn = dn + cross(Jj.w, tq);
                dn = sign * dn;
                const Force Hj = cross(Jj, F);  // F . (J_j x J_k) = -J_k . (J_j x* F)
                for (int k = 0; k < nv; ++k) {
                    if (!w.anc[b * nb + w.owner[k]]) continue;
                    const Motion& Jk = d.J[k];
                    double y = dot(Jk.w, dn);
                    if (inb && w.anc[w.owner[k] * nb + w.owner[j]])  // q_j turns the axis J_k: J_j x J_k
                        y -= dot(Jk.w, Hj.n) + dot(Jk.v, Hj.f);
                    P[k * nv + j] += y;
                }
            }
        }
    }
}

// K = Y Y^T (m x m) for Y (m x nv).
void gram(const double* Y, int m, int nv, double* K) {
    for (int r = 0; r < m; ++r)
        for (int s = r; s < m; ++s) {
            double y = 0.0;
            for (int k = 0; k < nv; ++k) y += Y[r * nv + k] * Y[s * nv + k];
            K[r * m + s] = y;
            K[s * m + r] = y;
        }
}

// Each row c of XT (nv) and RT (m) holds a column of X and Z; replaced by the column of da and dlam:
// dlam = K^+ (Z - J M^-1 X), da = M^-1 (X + J^T dlam), M^-1 = L^-1 L^-T and J M^-1 = Y^T L^-T from the dynamics'
// factors.  The products run as axpy loops over contiguous rows (Y^T, and K^-1 formed once when K is regular).
// Returns false when K is singular (dependent rows: the minimum-norm solve).
bool kkt_columns(int nv, int m, ConstrainedDerivativesData& w) {
    ConstrainedData& cd = w.cd;
    const double *LM = cd.L.data(), *Y = cd.Y.data();
    const int* lam = cd.lam.data();
    double *K = w.K.data(), *Kinv = w.Kinv.data(), *YT = w.YT.data(), *LK = cd.LK.data(), *x = w.x.data();
    gram(Y, m, nv, K);
    double dmax = 0.0;
    for (int r = 0; r < m; ++r) {
        std::copy(K + r * m, K + (r + 1) * m, LK + r * m);
        dmax = std::max(dmax, K[r * m + r]);
        for (int k = 0; k < nv; ++k) YT[k * m + r] = Y[r * nv + k];
    }
    const bool full = dmax > 0.0 && cholesky(LK, m, m, CHOLESKY_RTOL * dmax);
    if (full)  // K^-1 row by row (symmetric)
        for (int r = 0; r < m; ++r) {
            for (int s = 0; s < m; ++s) Kinv[r * m + s] = r == s ? 1.0 : 0.0;
            lower_solve(LK, m, m, Kinv + r * m);
            upper_solve(LK, m, m, Kinv + r * m);
        }
    for (int c = 0; c < 3 * nv; ++c) {
        double *xc = w.XT.data() + c * nv, *z = w.RT.data() + c * m;
        ltl_solve_t(LM, lam, nv, xc);
        std::copy(z, z + m, x);
        for (int k = 0; k < nv; ++k) {  // x = z - Y w
            const double wk = xc[k];
            if (wk != 0.0)
                for (int r = 0; r < m; ++r) x[r] -= YT[k * m + r] * wk;
        }
        if (full) {
            std::fill(z, z + m, 0.0);
            for (int r = 0; r < m; ++r) {
                const double xr = x[r];
                for (int s = 0; s < m; ++s) z[s] += Kinv[r * m + s] * xr;
            }
        } else {  // the dynamics' minimum-norm solve (it overwrites K: rebuilt each time)
            gram(Y, m, nv, K);
            pinv_solve(K, m, x, RANK_RTOL, z, LK, cd.piv.data(), cd.t.data());
        }
        for (int r = 0; r < m; ++r) {  // w += Y^T z
            const double zr = z[r];
            for (int k = 0; k < nv; ++k) xc[k] += Y[r * nv + k] * zr;
        }
        ltl_solve(LM, lam, nv, xc);
    }
    return full;
}

// Rows 0..nv-1 of RT (dlam along each q_j) += N d(J w)/dq_j with w = J^+ lambda and N = 1 - Q Q^T the projector
// onto null(J^T), Q an orthonormal basis of range(J J^T) = B R^-T (J J^T = B B^T, Cholesky with diagonal pivoting;
// R R^T = B^T B).  Overwrites the derivatives' forward pass.
void null_space_term(const Model& model, const Constraints& con, ConstrainedDerivativesData& w, const double* q) {
    const int m = con.m, nv = model.nv;
    const double* J = w.cd.J.data();
    double *JJ = w.JJ.data(), *L = w.LN.data(), *Gm = w.Gm.data(), *Q = w.Q.data(), *t = w.t.data();
    int* piv = w.piv.data();
    double dmax = 0.0;
    for (int r = 0; r < m; ++r) {
        for (int c = 0; c < m; ++c) {
            double y = 0.0;
            for (int k = 0; k < nv; ++k) y += J[r * nv + k] * J[c * nv + k];
            JJ[r * m + c] = y;
            Q[r * m + c] = y;
        }
        dmax = std::max(dmax, JJ[r * m + r]);
    }
    pinv_solve(Q, m, w.lam.data(), RANK_RTOL, w.s.data(), L, piv, t);  // J J^T s = lambda; Q as scratch
    for (int k = 0; k < nv; ++k) {  // w = J^T s = J^+ lambda
        double y = 0.0;
        for (int r = 0; r < m; ++r) y += J[r * nv + k] * w.s[r];
        w.w[k] = y;
        w.zero[k] = 0.0;
    }
    const int rank = pivoted_cholesky(JJ, m, RANK_RTOL * dmax, L, piv);  // B[piv[i]] = L[i, :rank]
    for (int a = 0; a < rank; ++a)
        for (int b = 0; b <= a; ++b) {
            double y = 0.0;
            for (int r = 0; r < m; ++r) y += L[r * m + a] * L[r * m + b];
            Gm[a * m + b] = y;
        }
    cholesky(Gm, m, rank, 0.0);
    for (int i = 0; i < m; ++i) {  // row piv[i] of Q = R^-1 (row i of L)
        for (int a = 0; a < rank; ++a) t[a] = L[i * m + a];
        lower_solve(Gm, m, rank, t);
        for (int a = 0; a < rank; ++a) Q[piv[i] * m + a] = t[a];
    }
    // the kinematics at velocity w (acceleration and gravity zero), then G = d(J w)/dq
    derivatives_forward_pass(model, w.rd, q, w.w.data(), w.zero.data(), Vec3{}, nullptr);
    row_partials(model, con, w.rd, w, 0.0, 0.5, 0.0, w.G.data(), w.H.data());
    const double* G = w.G.data();
    for (int j = 0; j < nv; ++j) {  // RT[j] += G[:, j] - Q Q^T G[:, j]
        for (int a = 0; a < rank; ++a) {
            double y = 0.0;
            for (int r = 0; r < m; ++r) y += Q[r * m + a] * G[r * nv + j];
            t[a] = y;
        }
        for (int r = 0; r < m; ++r) {
            double y = G[r * nv + j];
            for (int a = 0; a < rank; ++a) y -= Q[r * m + a] * t[a];
            w.RT[j * m + r] += y;
        }
    }
}

}  // namespace

int constrained_forward_dynamics_derivatives(const Model& model, const Constraints& con, Data& data,
                                             ConstrainedDerivativesData& w, const double* q, const double* v,
                                             const double* tau, const Vec3& gravity, double alpha, double beta,
                                             double* out) {
    const int nv = model.nv, m = con.m;
    const int status = constrained_forward_dynamics(model, con, data, w.cd, q, v, tau, gravity, alpha, beta,
                                                    w.a.data(), w.lam.data());
    if (status >= 0) return status;
    rnea_derivatives(model, w.rd, q, v, w.a.data(), gravity, nullptr, w.dq.data(), w.dv.data(), w.M.data());
    row_partials(model, con, w.rd, w, 1.0, alpha, beta, w.G.data(), w.H.data());
    force_partials(model, con, w.rd, w, w.lam.data(), w.P.data());
    double *XT = w.XT.data(), *RT = w.RT.data();
    for (int c = 0; c < nv; ++c) {  // X = -dr1/dx, Z = -dr2/dx, column by column (rows of XT, RT)
        for (int k = 0; k < nv; ++k) {
            XT[c * nv + k] = w.P[k * nv + c] - w.dq[k * nv + c];
            XT[(nv + c) * nv + k] = -w.dv[k * nv + c];
            XT[(2 * nv + c) * nv + k] = k == c ? 1.0 : 0.0;
        }
        for (int r = 0; r < m; ++r) {
            RT[c * m + r] = -w.G[r * nv + c];
            RT[(nv + c) * m + r] = -w.H[r * nv + c];
            RT[(2 * nv + c) * m + r] = 0.0;
        }
    }
    if (!kkt_columns(nv, m, w)) null_space_term(model, con, w, q);  // dependent rows
    const long n = nv + m;
    for (int c = 0; c < 3 * nv; ++c) {
        const int i = c / nv, j = c % nv;
        for (int k = 0; k < nv; ++k) out[(i * n + k) * nv + j] = XT[c * nv + k];
        for (int r = 0; r < m; ++r) out[(i * n + nv + r) * nv + j] = RT[c * m + r];
    }
    return -1;
}

}  // namespace core
