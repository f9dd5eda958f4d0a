// The Jacobians of integrate and difference (configuration_jacobians.hpp has the equations).
#include "configuration_jacobians.hpp"

#include <algorithm>
#include <cmath>

#include "joints.hpp"

namespace core {

namespace {

Mat3 scaled(double s, const Mat3& A) {
    Mat3 B;
    for (int k = 0; k < 9; ++k) B[k] = s * A[k];
    return B;
}
Mat3 minus(const Mat3& A, const Mat3& B) { return A + scaled(-1.0, B); }
double norm(const Vec3& x) { return std::sqrt(dot(x, x)); }

// 1 + a [phi] + b [phi]^2
Mat3 so3_poly(const Vec3& phi, double a, double b) {
    const Mat3 K = skew(phi), KK = K * K;
    Mat3 out = Mat3::identity();
    for (int k = 0; k < 9; ++k) out[k] = out[k] + a * K[k] + b * KK[k];
    return out;
}

Mat3 so3_exp(const Vec3& phi) {
    const double t = norm(phi);
    if (t < 1e-6) return so3_poly(phi, 1.0 - t * t / 6.0, 0.5 - t * t / 24.0);
    return so3_poly(phi, std::sin(t) / t, (1.0 - std::cos(t)) / (t * t));
}

// Jl(phi), by its series below t = 1e-4
Mat3 so3_left_jacobian(const Vec3& phi) {
    const double t = norm(phi);
    if (t < 1e-4) return so3_poly(phi, 0.5 - t * t / 24.0, 1.0 / 6.0 - t * t / 120.0);
    return so3_poly(phi, (1.0 - std::cos(t)) / (t * t), (t - std::sin(t)) / (t * t * t));
}

// Barfoot's Q(rho, phi), the upper right block of the left Jacobian of SE(3) (eq. 7.86)
Mat3 se3_q(const Vec3& rho, const Vec3& phi) {
    const double t = norm(phi);
    double c1, c2, c3;
    if (t < 1e-3) {
        c1 = 1.0 / 6.0 - t * t / 120.0, c2 = 1.0 / 24.0 - t * t / 720.0, c3 = 1.0 / 120.0 - t * t / 2520.0;
    } else {
        const double s = std::sin(t), c = std::cos(t), t2 = t * t;
        c1 = (t - s) / (t2 * t);
        c2 = (t2 + 2.0 * c - 2.0) / (2.0 * t2 * t2);
        c3 = (2.0 * t - 3.0 * s + t * c) / (2.0 * t2 * t2 * t);
    }
    const Mat3 P = skew(phi), R = skew(rho), PR = P * R, RP = R * P, PRP = PR * P;
    return scaled(0.5, R) + scaled(c1, PR + RP + PRP) + scaled(c2, minus(P * PR + RP * P, scaled(3.0, PRP))) +
           scaled(c3, PRP * P + P * PRP);
}

// A 6x6 matrix [[A, B], [0, C]] from its 3x3 blocks.
Mat6 blocks(const Mat3& A, const Mat3& B, const Mat3& C) {
    Mat6 M;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            M(r, c) = A[3 * r + c], M(r, 3 + c) = B[3 * r + c];
            M(3 + r, c) = 0.0, M(3 + r, 3 + c) = C[3 * r + c];
        }
    return M;
}

// Jr(xi) = Jl(-xi), xi = (rho, phi) (linear, angular)
Mat6 se3_right_jacobian(const Vec3& rho, const Vec3& phi) {
    const Mat3 J = so3_left_jacobian(-phi);
    return blocks(J, se3_q(-rho, -phi), J);
}

// Ad(Exp(xi))^-1 = Ad(Exp(-xi)) in (linear, angular) order
Mat6 se3_adjoint_inverse(const Vec3& rho, const Vec3& phi) {
    const Mat3 R = so3_exp(-phi);
    const Vec3 p = rot(so3_left_jacobian(-phi), -rho);
    return blocks(R, skew(p) * R, R);
}

// Joint i's tangent as coordinates of the free joint's (linear, angular) twist: n of them into idx; 0 for a
// 1-dof joint.
int embedding(int type, int* idx) {
    static const int free[6] = {0, 1, 2, 3, 4, 5}, spherical[3] = {3, 4, 5}, planar[3] = {0, 1, 5};
    const int* e = type == JOINT_FREE ? free : type == JOINT_SPHERICAL ? spherical : type == JOINT_PLANAR ? planar
                                                                                                            : nullptr;
    const int n = e ? joint_nv(type) : 0;
    for (int k = 0; k < n; ++k) idx[k] = e[k];
    return n;
}

// The joint's twist (rho, phi) from its tangent x (zero outside its subgroup).
void twist(const int* idx, int n, const double* x, Vec3& rho, Vec3& phi) {
    double xi[6] = {0, 0, 0, 0, 0, 0};
    for (int k = 0; k < n; ++k) xi[idx[k]] = x[k];
    rho = {xi[0], xi[1], xi[2]}, phi = {xi[3], xi[4], xi[5]};
}

// out[kv + r, kv + c] = M[idx[r], idx[c]]
void put_block(const Mat6& M, const int* idx, int n, int nv, int kv, double* out) {
    for (int r = 0; r < n; ++r)
        for (int c = 0; c < n; ++c) out[(kv + r) * nv + kv + c] = M(idx[r], idx[c]);
}

// Ainv = A^-1 for an n x n matrix (row-major, leading dimension 6) by Gauss-Jordan with partial pivoting; false if
// singular.
bool inverse(const double* A0, int n, double* Ainv) {
    double A[36];
    for (int r = 0; r < n; ++r)
        for (int c = 0; c < n; ++c) A[6 * r + c] = A0[6 * r + c], Ainv[6 * r + c] = r == c ? 1.0 : 0.0;
    for (int k = 0; k < n; ++k) {
        int p = k;
        for (int r = k + 1; r < n; ++r)
            if (std::abs(A[6 * r + k]) > std::abs(A[6 * p + k])) p = r;
        if (!(A[6 * p + k] != 0.0)) return false;
        for (int c = 0; c < n; ++c) std::swap(A[6 * k + c], A[6 * p + c]), std::swap(Ainv[6 * k + c], Ainv[6 * p + c]);
        const double inv = 1.0 / A[6 * k + k];
        for (int c = 0; c < n; ++c) A[6 * k + c] *= inv, Ainv[6 * k + c] *= inv;
        for (int r = 0; r < n; ++r) {
            const double f = A[6 * r + k];
            if (r == k || f == 0.0) continue;
            for (int c = 0; c < n; ++c) A[6 * r + c] -= f * A[6 * k + c], Ainv[6 * r + c] -= f * Ainv[6 * k + c];
        }
    }
    return true;
}

}  // namespace

void integrate_jacobians(const Model& model, const double* v, double* Jq, double* Jv) {
    const int nv = model.nv;
    std::fill(Jq, Jq + static_cast<long>(nv) * nv, 0.0), std::fill(Jv, Jv + static_cast<long>(nv) * nv, 0.0);
    for (int i = 0; i < model.nb; ++i) {
        const int kv = model.v_idx[i];
        int idx[6];
        const int n = embedding(model.jtype[i], idx);
        if (n == 0) {
            Jq[kv * nv + kv] = Jv[kv * nv + kv] = 1.0;
            continue;
        }
        Vec3 rho, phi;
        twist(idx, n, v + kv, rho, phi);
        put_block(se3_adjoint_inverse(rho, phi), idx, n, nv, kv, Jq);
        put_block(se3_right_jacobian(rho, phi), idx, n, nv, kv, Jv);
    }
}

bool difference_jacobians(const Model& model, const double* d, double* J0, double* J1) {
    const int nv = model.nv;
    std::fill(J0, J0 + static_cast<long>(nv) * nv, 0.0), std::fill(J1, J1 + static_cast<long>(nv) * nv, 0.0);
    for (int i = 0; i < model.nb; ++i) {
        const int kv = model.v_idx[i];
        int idx[6];
        const int n = embedding(model.jtype[i], idx);
        if (n == 0) {
            J0[kv * nv + kv] = -1.0, J1[kv * nv + kv] = 1.0;
            continue;
        }
        Vec3 rho, phi;
        twist(idx, n, d + kv, rho, phi);
        const Mat6 Jr = se3_right_jacobian(rho, phi), Ad = se3_adjoint_inverse(rho, phi);
        double Jr_n[36], Jlog[36];  // the joint's blocks, leading dimension 6
        for (int r = 0; r < n; ++r)
            for (int c = 0; c < n; ++c) Jr_n[6 * r + c] = Jr(idx[r], idx[c]);
        if (!inverse(Jr_n, n, Jlog)) return false;
        for (int r = 0; r < n; ++r)
            for (int c = 0; c < n; ++c) {
                J1[(kv + r) * nv + kv + c] = Jlog[6 * r + c];
                double x = 0.0;  // -Jr^-1 Ad^-1
                for (int k = 0; k < n; ++k) x += -Jlog[6 * r + k] * Ad(idx[k], idx[c]);
                J0[(kv + r) * nv + kv + c] = x;
            }
    }
    return true;
}

}  // namespace core
