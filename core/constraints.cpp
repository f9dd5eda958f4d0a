// The loop constraints' terms (constraints.hpp has the rows and the kinematics).
#include "constraints.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "joints.hpp"
#include "kinematics.hpp"

namespace core {

static void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("constraints: " + what);
}

void check(const Model& model, Constraints& con) {
    const size_t nc = static_cast<size_t>(con.nc);
    require(con.nc >= 0, "negative count");
    require(con.kind.size() == nc && con.row.size() == nc && con.body.size() == 2 * nc && con.idx.size() == 4 * nc &&
                con.R.size() == 2 * nc && con.p.size() == 2 * nc && con.coef.size() == 2 * nc,
            "the arrays do not have nc rows");
    int m = 0;
    for (int c = 0; c < con.nc; ++c) {
        const std::string at = "constraint " + std::to_string(c) + ": ";
        const int k = con.kind[c];
        require(k >= POINT && k <= COUPLING, at + "unknown kind " + std::to_string(k));
        require(con.row[c] == m, at + "rows are not consecutive");
        m += constraint_rows(k);
        if (k == COUPLING) {
            for (int s = 0; s < 2; ++s) {
                const int qi = con.idx[4 * c + 2 * s], vi = con.idx[4 * c + 2 * s + 1];
                require(qi >= 0 && qi < model.nq && vi >= 0 && vi < model.nv, at + "coordinate out of range");
            }
            require(std::isfinite(con.coef[2 * c]) && std::isfinite(con.coef[2 * c + 1]), at + "non-finite coefficient");
            continue;
        }
        for (int s = 0; s < 2; ++s) {
            const int b = con.body[2 * c + s];
            require(b >= -1 && b < model.nb, at + "body out of range");
            for (int e = 0; e < 9; ++e) require(std::isfinite(con.R[2 * c + s][e]), at + "non-finite anchor axes");
            const Vec3& x = con.p[2 * c + s];
            require(std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z), at + "non-finite anchor origin");
        }
    }
    require(con.m == m, "m is not the sum of the constraints' rows");
    con.nb = model.nb, con.nq = model.nq, con.nv = model.nv;
}

namespace {

// World poses (data.oMi), motion axes oS_k and, with v, V_i and A_i of every body (world, at the world origin).
void body_motion(const Model& model, Data& data, ConstraintWork& w, const double* q, const double* v) {
    for (int i = 0; i < model.nb; ++i) {
        world_pose(model, data, i, q);
        const Transform& T = data.oMi[i];
        Motion vJ;
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            const Vec3 s = rot(T.R, model.S[k].w);
            const Vec3 u = rot(T.R, model.S[k].v) + cross(T.p, s);
            w.oS[k] = {s, u};
            if (v) vJ = {vJ.w + v[k] * s, vJ.v + v[k] * u};
        }
        if (!v) continue;
        const int par = model.parents[i];
        const Motion Vp = par >= 0 ? w.V[par] : Motion{}, Ap = par >= 0 ? w.A[par] : Motion{};
        const Motion Vi = {Vp.w + vJ.w, Vp.v + vJ.v};
        const Motion c = cross(Vi, vJ);
        w.V[i] = Vi;
        w.A[i] = {Ap.w + c.w, Ap.v + c.v};
    }
}

// World axes and origin of anchor s (0: a, 1: b) of constraint c.
Transform anchor_pose(const Constraints& con, const Data& data, int c, int s) {
    const int b = con.body[2 * c + s];
    const Mat3& R = con.R[2 * c + s];
    const Vec3& p = con.p[2 * c + s];
    if (b < 0) return {R, p};
    const Transform& B = data.oMi[b];
    return {B.R * R, rot(B.R, p) + B.p};
}

// An anchor's velocity (linear at the world point x, angular) and classical bias acceleration (linear, angular).
struct AnchorMotion {
    Vec3 lin, w, acc, alpha;
};
AnchorMotion anchor_motion(const ConstraintWork& w, int b, const Vec3& x) {
    if (b < 0) return {};
    const Motion& V = w.V[b];
    const Motion& A = w.A[b];
    const Vec3 lin = V.v + cross(V.w, x);
    return {lin, V.w, (A.v + cross(A.w, x)) + cross(V.w, lin), A.w};
}

// J[r:r+3] += sign * the linear velocity columns at world point x, then J[ra + t] += sign * D[t] . the angular
// columns (t < nang; ra = r + 3), over the support of body b.
void add_columns(const Model& model, const ConstraintWork& w, int b, const Vec3& x, double sign, double* J, int r,
                 const Vec3* D, int nang) {
    const int nv = model.nv;
    for (int j = b; j >= 0; j = model.parents[j]) {
        for (int k = model.v_idx[j]; k < model.v_idx[j] + model.nv_j[j]; ++k) {
            const Motion& s = w.oS[k];
            const Vec3 vx = s.v + cross(s.w, x);
            J[r * nv + k] += sign * vx.x;
            J[(r + 1) * nv + k] += sign * vx.y;
            J[(r + 2) * nv + k] += sign * vx.z;
            for (int t = 0; t < nang; ++t) J[(r + 3 + t) * nv + k] += sign * dot(D[t], s.w);
        }
    }
}

Vec3 column(const Mat3& R, int k) { return {R[k], R[3 + k], R[6 + k]}; }

}  // namespace

void constraint_terms(const Model& model, const Constraints& con, Data& data, ConstraintWork& w, const double* q,
                      const double* v, double* phi, double* J, double* gamma) {
    body_motion(model, data, w, q, gamma ? v : nullptr);
    const int nv = model.nv;
    if (J) std::fill(J, J + static_cast<size_t>(con.m) * nv, 0.0);
    const Vec3 E[3] = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};
    for (int c = 0; c < con.nc; ++c) {
        const int kind = con.kind[c], r = con.row[c];
        if (kind == COUPLING) {  // q_f - (k q_l + offset)
            const int qf = con.idx[4 * c], vf = con.idx[4 * c + 1], ql = con.idx[4 * c + 2], vl = con.idx[4 * c + 3];
            const double mult = con.coef[2 * c];
            phi[r] = q[qf] - mult * q[ql] - con.coef[2 * c + 1];
            if (J) J[r * nv + vf] += 1.0, J[r * nv + vl] -= mult;
            if (gamma) gamma[r] = 0.0;
            continue;
        }
        const Transform Ta = anchor_pose(con, data, c, 0), Tb = anchor_pose(con, data, c, 1);
        const Vec3 &xa = Ta.p, &xb = Tb.p;
        const int ba = con.body[2 * c], bb = con.body[2 * c + 1];
        phi[r] = xa.x - xb.x, phi[r + 1] = xa.y - xb.y, phi[r + 2] = xa.z - xb.z;
        const Vec3 t1 = column(Ta.R, 0), t2 = column(Ta.R, 1);
        Vec3 D[3] = {E[0], E[1], E[2]};
        int nang = 0;
        if (kind == WELD) {  // log(R_A R_B^T)
            const Vec3 e = rotation_log(Ta.R * transpose(Tb.R));
            phi[r + 3] = e.x, phi[r + 4] = e.y, phi[r + 5] = e.z;
            nang = 3;
        } else if (kind == REVOLUTE) {  // t_k . (u_B x u_A)
            const Vec3 n = cross(column(Tb.R, 2), column(Ta.R, 2));
            phi[r + 3] = dot(t1, n), phi[r + 4] = dot(t2, n);
            D[0] = t1, D[1] = t2, nang = 2;
        }
        if (J) {
            add_columns(model, w, ba, xa, 1.0, J, r, D, nang);
            add_columns(model, w, bb, xb, -1.0, J, r, D, nang);
        }
        if (gamma) {
            const AnchorMotion A = anchor_motion(w, ba, xa), B = anchor_motion(w, bb, xb);
            gamma[r] = A.acc.x - B.acc.x, gamma[r + 1] = A.acc.y - B.acc.y, gamma[r + 2] = A.acc.z - B.acc.z;
            const Vec3 dw = A.w + (-1.0) * B.w, dal = A.alpha + (-1.0) * B.alpha;
            if (kind == WELD) {
                gamma[r + 3] = dal.x, gamma[r + 4] = dal.y, gamma[r + 5] = dal.z;
            } else if (kind == REVOLUTE) {
                gamma[r + 3] = dot(cross(A.w, t1), dw) + dot(t1, dal);
                gamma[r + 4] = dot(cross(A.w, t2), dw) + dot(t2, dal);
            }
        }
    }
}

}  // namespace core
