// Derivatives of the generalised contact force (force_derivatives.hpp), in the order of operations of
// dynamics/contact/force_derivatives.py.
#include "contact/force_derivatives.hpp"

#include <algorithm>
#include <cmath>

#include "contact/forces.hpp"

namespace core::contact {

namespace {

// A[:, j] += sign * the world velocity of body's material point at P per unit of dof j, for the dofs of body and
// its ancestors (nothing for the world, body -1).
void point_jacobian(const Model& model, const Transform* oMi, int64_t body, const Vec3& P, double sign, double* A,
                    int nv) {
    for (int64_t i = body; i >= 0; i = model.parents[i]) {
        const Mat3& R = oMi[i].R;
        const Vec3 r = P - oMi[i].p;
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            const Vec3 w = rot(R, model.S[k].w), u = rot(R, model.S[k].v);
            const Vec3 wr = cross(w, r);
            for (int m = 0; m < 3; ++m) A[m * nv + k] += sign * (u[m] + wr[m]);
        }
    }
}

// (c, dc/d|v_t|) at slip speed `speed` >= 0 (c: friction_ratio).
void friction_slope(double speed, const double* mat, double& c, double& dc) {
    const double vs = mat[K_VS], mu_s = mat[K_MU_S], mu_d = mat[K_MU_D];
    c = friction_ratio(speed, mat);
    if (speed < vs) {  // c = mu_s (2 - s) / v_s
        dc = -mu_s / (vs * vs);
        return;
    }
    const double s = speed / vs;
    const double mu = friction_coefficient(s, mu_s, mu_d);
    if (s >= 3.0) {  // c = mu_d / speed
        dc = -mu / (speed * speed);
        return;
    }
    const double x = 0.5 * (s - 1.0);  // mu = mu_s - (mu_s - mu_d) step5(x)
    const double dmu = -(mu_s - mu_d) * 15.0 * x * x * (1.0 - x) * (1.0 - x);
    dc = dmu / (vs * speed) - mu / (speed * speed);
}

// G (3 x 3, row-major) = dF/dv_rel and Fx = dF/dx of one contact.
void force_derivatives(const Vec3& n, double x, const Vec3& vrel, const double* mat, double* G, double* Fx) {
    const double vn = dot(n, vrel);
    const double damp = std::max(0.0, 1.0 - mat[K_DISS] * vn);
    const double fn = mat[K_STIFF] * x * damp;
    const double gn = damp > 0.0 ? -mat[K_STIFF] * x * mat[K_DISS] : 0.0;  // d f_n / d v_rel = gn n
    const Vec3 vt{vrel.x - vn * n.x, vrel.y - vn * n.y, vrel.z - vn * n.z};
    const double speed = std::sqrt(dot(vt, vt));
    double c, dc;
    friction_slope(speed, mat, c, dc);
    const double e = speed > 0.0 ? dc / speed : 0.0;
    for (int r = 0; r < 3; ++r) {
        for (int m = 0; m < 3; ++m) {
            const double Pt = (r == m ? 1.0 : 0.0) - n[r] * n[m];
            G[3 * r + m] = n[r] * gn * n[m] - fn * (c * Pt + e * vt[r] * vt[m]) - c * vt[r] * gn * n[m];
        }
        Fx[r] = mat[K_STIFF] * damp * (n[r] - c * vt[r]);
    }
}

}  // namespace

void contact_force_derivatives(const Model& model, int64_t n, const ContactBuffer& buf, const int64_t* pair_body,
                               const double* mat, const Transform* oMi, const double* v, double* dq, double* dv,
                               ForceDerivativesWork& w) {
    const int nv = model.nv;
    std::fill(dq, dq + nv * nv, 0.0);
    std::fill(dv, dv + nv * nv, 0.0);
    double *A = w.A.data(), *GA = w.GA.data(), *nA = w.nA.data();
    double G[9], Fx[3];
    for (int64_t k = 0; k < n; ++k) {
        const int64_t j = buf.pair[k];
        const Vec3 &P = buf.point[k], &nrm = buf.normal[k];
        std::fill(A, A + 3 * nv, 0.0);
        point_jacobian(model, oMi, pair_body[2 * j], P, 1.0, A, nv);
        point_jacobian(model, oMi, pair_body[2 * j + 1], P, -1.0, A, nv);
        // the dofs that move the point (the others' columns of A are zero: their terms would add zeros, which
        // change no bit of a finite sum)
        int* dofs = w.dofs.data();
        int nd = 0;
        for (int c = 0; c < nv; ++c)
            if (A[c] != 0.0 || A[nv + c] != 0.0 || A[2 * nv + c] != 0.0) dofs[nd++] = c;
        Vec3 vrel;
        for (int i = 0; i < nd; ++i) {
            const int c = dofs[i];
            vrel = {vrel.x + A[c] * v[c], vrel.y + A[nv + c] * v[c], vrel.z + A[2 * nv + c] * v[c]};
        }
        force_derivatives(nrm, buf.depth[k], vrel, mat + NMAT * j, G, Fx);
        for (int i = 0; i < nd; ++i) {
            const int c = dofs[i];
            for (int m = 0; m < 3; ++m)
                GA[m * nv + c] = G[3 * m] * A[c] + G[3 * m + 1] * A[nv + c] + G[3 * m + 2] * A[2 * nv + c];
            nA[c] = nrm.x * A[c] + nrm.y * A[nv + c] + nrm.z * A[2 * nv + c];
        }
        for (int i = 0; i < nd; ++i) {
            const int r = dofs[i];
            const double a0 = A[r], a1 = A[nv + r], a2 = A[2 * nv + r];
            const double ax = a0 * Fx[0] + a1 * Fx[1] + a2 * Fx[2];
            for (int l = 0; l < nd; ++l) {
                const int c = dofs[l];
                dv[r * nv + c] += a0 * GA[c] + a1 * GA[nv + c] + a2 * GA[2 * nv + c];
                dq[r * nv + c] -= ax * nA[c];
            }
        }
    }
}

}  // namespace core::contact
