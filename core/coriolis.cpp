// The Coriolis matrix (coriolis.hpp has the equations).  Its per-call arrays (J and dJ per body, O(nb nv)) are
// its own: it is not an inner-loop algorithm.
#include "coriolis.hpp"

#include <algorithm>
#include <vector>

#include "joints.hpp"

namespace core {

// B = 1/2 (v x* I + I v x + (I v) xbar) for the 6x6 inertia I and motion m.
static void cross_matrices(const Mat6& I, const Motion& m, Mat6& B) {
    Mat6 crm = {}, xbar = {};  // v x;  (n, f) xbar = [[-[n]x, -[f]x], [-[f]x, 0]]
    const Mat3 W = skew(m.w), V = skew(m.v);
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            crm(r, c) = crm(3 + r, 3 + c) = W[3 * r + c];
            crm(3 + r, c) = V[3 * r + c];
        }
    double w[6], h[6] = {0, 0, 0, 0, 0, 0};
    to_array(m, w);
    for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 3; ++c) h[r] += I(r, c) * w[c] + I(r, 3 + c) * w[3 + c];
    const Mat3 Hn = skew({h[0], h[1], h[2]}), Hf = skew({h[3], h[4], h[5]});
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            xbar(r, c) = -Hn[3 * r + c];
            xbar(r, 3 + c) = xbar(3 + r, c) = -Hf[3 * r + c];
        }
    for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) {
            double s = xbar(r, c);
            for (int k = 0; k < 6; ++k) s += -crm(k, r) * I(k, c) + I(r, k) * crm(k, c);  // v x* = -(v x)^T
            B(r, c) = 0.5 * s;
        }
}

void coriolis_matrix(const Model& model, Data& data, const double* q, const double* v, double* C) {
    const int nb = model.nb, nv = model.nv;
    forward_pass(model, data, q, v, true);  // X_i, v_i
    // J[i] and dJ[i]: body i's Jacobian and its derivative, nv columns of 6 numbers; cols: which can be non-zero
    std::vector<double> J(static_cast<size_t>(nb) * nv * 6, 0.0), dJ(J.size(), 0.0), Y(6 * static_cast<size_t>(nv));
    std::vector<char> cols(static_cast<size_t>(nb) * nv, 0);
    auto at = [&](std::vector<double>& A, int i, int k) { return A.data() + (static_cast<size_t>(i) * nv + k) * 6; };
    std::fill(C, C + static_cast<size_t>(nv) * nv, 0.0);
    Mat6 Bm;
    for (int i = 0; i < nb; ++i) {
        const Transform& X = data.X[i];
        const int par = model.parents[i];
        const Motion vJ = joint_motion(model, i, v);
        if (par >= 0)  // J_i = X_i J_p (+ S_i),  dJ_i = X_i dJ_p + J_i x v_J (Featherstone 2008, sec. 7.2)
            for (int k = 0; k < nv; ++k) {
                if (!cols[static_cast<size_t>(par) * nv + k]) continue;
                cols[static_cast<size_t>(i) * nv + k] = 1;
                const Motion j = motion_to_child(X, motion_from(at(J, par, k)));
                const Motion dj = motion_to_child(X, motion_from(at(dJ, par, k))) + cross(j, vJ);
                to_array(j, at(J, i, k));
                to_array(dj, at(dJ, i, k));
            }
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            cols[static_cast<size_t>(i) * nv + k] = 1;
            to_array(model.S[k], at(J, i, k));
        }
        const Mat6 I6 = to_matrix({model.I[i].m, model.I[i].h, model.I[i].Io});
        cross_matrices(I6, data.v[i], Bm);
        for (int c = 0; c < nv; ++c) {
            if (!cols[static_cast<size_t>(i) * nv + c]) continue;
            const double *j = at(J, i, c), *dj = at(dJ, i, c);
            for (int r = 0; r < 6; ++r) {
                double x = 0.0;
                for (int k = 0; k < 6; ++k) x += I6(r, k) * dj[k] + Bm(r, k) * j[k];
                Y[static_cast<size_t>(r) * nv + c] = x;
            }
        }
        for (int a = 0; a < nv; ++a) {
            if (!cols[static_cast<size_t>(i) * nv + a]) continue;
            const double* ja = at(J, i, a);
            for (int c = 0; c < nv; ++c) {
                if (!cols[static_cast<size_t>(i) * nv + c]) continue;
                double x = 0.0;
                for (int r = 0; r < 6; ++r) x += ja[r] * Y[static_cast<size_t>(r) * nv + c];
                C[static_cast<size_t>(a) * nv + c] += x;
            }
        }
    }
}

}  // namespace core
