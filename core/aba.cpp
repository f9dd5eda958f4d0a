// Forward dynamics by the ABA (aba.hpp has the equations).
#include "aba.hpp"

#include "joints.hpp"

namespace core {

void aba_rigid_body_pass(const Model& model, Data& data, const double* q, const double* v, const double* f_ext,
                         bool with_v) {
    revolute_sines(model, data, q);  // first (data.hpp)
    for (int i = 0; i < model.nb; ++i) {
        data.X[i] = transform_after_sines(model, data, i, q);
        forward_motion(model, data, i, v, with_v);
        const Inertia& I = model.I[i];
        Force b = with_v ? cross(data.v[i], I * data.v[i]) : Force{};
        data.IA[i] = to_matrix(I);  // I^A = I_i
        if (f_ext) b = b - force_from_api(f_ext + 6 * i);
        data.pA[i] = b;
    }
}

// U = I^A S, u = tau - S^T p^A and D = S^T U for the nj columns of S from k0 (U[a]: column a as 6 numbers).
static void joint_columns(const Model& model, int k0, int nj, const Mat6& IA, const double* pA, const double* tau,
                          double (*U)[6], Data& data, double* D) {
    for (int a = 0; a < nj; ++a) {
        const int k = k0 + a;
        double s[6];
        to_array(model.S[k], s);
        for (int r = 0; r < 6; ++r) {
            double x = 0.0;
            for (int c = 0; c < 6; ++c) x += IA(r, c) * s[c];
            U[a][r] = x;
        }
        data.U[k] = force_from(U[a]);
        double x = tau[k];
        for (int r = 0; r < 6; ++r) x -= s[r] * pA[r];
        data.u[k] = x;
    }
    for (int a = 0; a < nj; ++a)
        for (int b = 0; b < nj; ++b) D[6 * a + b] = dot(model.S[k0 + a], data.U[k0 + b]);
}

// The same for a revolute joint about the body axis k (S = e_k): U is column k of I^A, u = tau - p^A_k and
// D = U_k, each non-zero number the general sums' (their other terms are products with S's zeros).
static void axis_column(int k, const Mat6& IA, const double* pA, double tau, double* U, Force& Uk, double& u,
                        double& D) {
    for (int r = 0; r < 6; ++r) U[r] = IA(r, k);
    Uk = force_from(U);
    u = tau - pA[k];
    D = U[k];
}

int aba_articulated_pass(const Model& model, Data& data, const double* tau) {
    double pA[6], pa[6], D[36], t[6], U[6][6];  // U[a]: joint i's a-th column of U, as 6 numbers
    Mat6 Ia;
    for (int i = model.nb - 1; i >= 0; --i) {
        const int k0 = model.v_idx[i], nj = model.nv_j[i];
        const Mat6& IA = data.IA[i];
        to_array(data.pA[i], pA);
        if (model.axis_k[i] >= 0)  // U = I^A S, u = tau - S^T p^A, D = S^T U
            axis_column(model.axis_k[i], IA, pA, tau[k0], U[0], data.U[k0], data.u[k0], D[0]);
        else
            joint_columns(model, k0, nj, IA, pA, tau, U, data, D);
        double* Dinv = data.Dinv[i].a;
        if (!spd_inverse(D, nj, Dinv)) return i;
        const int par = model.parents[i];
        if (par < 0) continue;
        Ia = IA;
        for (int r = 0; r < 6; ++r) pa[r] = pA[r];
        for (int a = 0; a < nj; ++a) {  // I^a = I^A - U D^-1 U^T,  p^a = p^A + U D^-1 u, one coordinate at a time
            double du = 0.0;
            for (int b = 0; b < nj; ++b) du += Dinv[6 * a + b] * data.u[k0 + b];
            for (int r = 0; r < 6; ++r) {
                double UD = 0.0;  // (U D^-1)[r, a]
                for (int b = 0; b < nj; ++b) UD += U[b][r] * Dinv[6 * b + a];
                for (int c = 0; c < 6; ++c) Ia(r, c) -= UD * U[a][c];
                pa[r] += U[a][r] * du;
            }
        }
        double c[6];  // p^a + I^a c_i
        to_array(data.c[i], c);
        for (int r = 0; r < 6; ++r)
            t[r] = pa[r] + Ia(r, 0) * c[0] + Ia(r, 1) * c[1] + Ia(r, 2) * c[2] + Ia(r, 3) * c[3] + Ia(r, 4) * c[4] +
                   Ia(r, 5) * c[5];
        add_inertia_to_parent(data.X[i], Ia, data.IA[par]);
        data.pA[par] = data.pA[par] + force_to_parent(data.X[i], force_from(t));
    }
    return -1;
}

void aba_acceleration_pass(const Model& model, Data& data, const Vec3& gravity, double* qdd) {
    const Motion a0 = {{}, -gravity};
    double t[6];
    for (int i = 0; i < model.nb; ++i) {
        const int par = model.parents[i];
        Motion ai = motion_to_child(data.X[i], par < 0 ? a0 : data.a[par]) + data.c[i];
        const int k0 = model.v_idx[i], nj = model.nv_j[i];
        for (int a = 0; a < nj; ++a) {  // u - U^T a'
            const Force& U = data.U[k0 + a];
            t[a] = data.u[k0 + a] - U.n.x * ai.w.x - U.n.y * ai.w.y - U.n.z * ai.w.z - U.f.x * ai.v.x -
                   U.f.y * ai.v.y - U.f.z * ai.v.z;
        }
        const double* Dinv = data.Dinv[i].a;
        for (int a = 0; a < nj; ++a) {
            double x = 0.0;
            for (int b = 0; b < nj; ++b) x += Dinv[6 * a + b] * t[b];
            qdd[k0 + a] = x;
        }
        data.a[i] = ai + joint_motion(model, i, qdd);
    }
}

void aba_bias_pass(const Model& model, Data& data, const Vec3& gravity, double* b) {
    const Motion a0 = {{}, -gravity};
    for (int i = 0; i < model.nb; ++i) {
        const int par = model.parents[i];
        data.a[i] = motion_to_child(data.X[i], par < 0 ? a0 : data.a[par]) + data.c[i];
        data.f[i] = model.I[i] * data.a[i] + data.pA[i];
    }
    for (int i = model.nb - 1; i >= 0; --i) {
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) b[k] = dot(model.S[k], data.f[i]);
        const int par = model.parents[i];
        if (par >= 0) data.f[par] = data.f[par] + force_to_parent(data.X[i], data.f[i]);
    }
}

int aba(const Model& model, Data& data, const double* q, const double* v, const double* tau, const Vec3& gravity,
        const double* f_ext, bool with_v, double* qdd) {
    aba_rigid_body_pass(model, data, q, v, f_ext, with_v);
    int singular = aba_articulated_pass(model, data, tau);
    if (singular >= 0) return singular;
    aba_acceleration_pass(model, data, gravity, qdd);
    return -1;
}

static Mat3 block(const Mat6& I, int r0, int c0) {
    Mat3 B;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) B[3 * r + c] = I(r0 + r, c0 + c);
    return B;
}

void add_inertia_to_parent(const Transform& X, const Mat6& Ia, Mat6& IA) {
    Mat3 A = rot_congruence(X.R, block(Ia, 0, 0));
    Mat3 B = rot_congruence(X.R, block(Ia, 0, 3));
    Mat3 C = rot_congruence(X.R, block(Ia, 3, 3));
    Mat3 P = skew(X.p);
    Mat3 CP = C * P, BP = B * P, PCP = P * CP;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
            IA(r, c) += A[3 * r + c] - BP[3 * r + c] - BP[3 * c + r] - PCP[3 * r + c];
            double t = B[3 * r + c] - CP[3 * c + r];
            IA(r, 3 + c) += t;
            IA(3 + c, r) += t;
            IA(3 + r, 3 + c) += C[3 * r + c];
        }
}

}  // namespace core
