// The operational-space controller (operational_space.hpp has the law).
#include "operational_space.hpp"

#include <algorithm>
#include <cmath>

#include "configuration.hpp"
#include "interpolation.hpp"
#include "jacobians.hpp"
#include "kinematics.hpp"
#include "minverse.hpp"
#include "rnea.hpp"

namespace core::control {

// Rodrigues' formula: exp([axis]x angle) for a unit axis.
static Mat3 rotation_about_axis(const Vec3& a, double angle) {
    const double c = std::cos(angle), s = std::sin(angle), t = 1.0 - c;
    return {{t * a.x * a.x + c, t * a.x * a.y - s * a.z, t * a.x * a.z + s * a.y, t * a.x * a.y + s * a.z,
             t * a.y * a.y + c, t * a.y * a.z - s * a.x, t * a.x * a.z - s * a.y, t * a.y * a.z + s * a.x,
             t * a.z * a.z + c}};
}

void orientation_at(const Source& src, double t, Mat3& Rd, Vec3& wd) {
    const int N = src.samples();
    const double* times = src.times.data();
    auto R_of = [&](int k) {
        Mat3 R;
        for (int i = 0; i < 9; ++i) R[i] = src.orientation[12 * k + i];
        return R;
    };
    if (N == 1 || t <= times[0] || t >= times[N - 1]) {
        Rd = R_of((N == 1 || t <= times[0]) ? 0 : N - 1), wd = {};
        return;
    }
    const int k = std::min(static_cast<int>(std::upper_bound(times, times + N, t) - times) - 1, N - 2);
    const double h = times[k + 1] - times[k];
    const double* o = &src.orientation[12 * k];
    const Vec3 psi = {o[9], o[10], o[11]};
    wd = {psi.x / h, psi.y / h, psi.z / h};
    const double angle = std::sqrt(psi.x * psi.x + psi.y * psi.y + psi.z * psi.z);
    Rd = R_of(k);
    if (angle == 0.0) return;
    const double s = (t - times[k]) / h;
    Rd = rotation_about_axis({psi.x / angle, psi.y / angle, psi.z / angle}, s * angle) * Rd;
}

void task_reference_at(const Source& src, double t, double* x_ref) {
    reference_at(src.times.data(), src.samples(), src.table.data(), 3, t, x_ref, x_ref + 3, x_ref + 6);
    if (t < src.times.front() || t > src.times.back()) std::fill(x_ref + 3, x_ref + 9, 0.0);
}

Transform operational_space_torques(const Model& model, const Source& src, const Vec3& gravity, SourceWorkspace& ws,
                                    double t, const double* q, const double* v, const double* tau_passive,
                                    double* tau) {
    const int nv = model.nv, r = static_cast<int>(src.rows.size()), f = src.frame;
    const int* rows = src.rows.data();
    double x_ref[9];
    task_reference_at(src, t, x_ref);
    std::fill(ws.J.begin(), ws.J.end(), 0.0);
    const double* J = ws.J.data();
    const Transform T = frame_jacobian(model, ws.data, q, f, LOCAL_WORLD_ALIGNED, {}, ws.J.data());
    frame_motion(model, ws.data, q, v, v, f, LOCAL_WORLD_ALIGNED, BIAS_ACCELERATION, true, ws.jdv);
    if (inverse_mass_matrix(model, ws.data, q, ws.Minv.data()) >= 0) {
        std::fill(tau, tau + nv, std::nan(""));
        return T;
    }
    // the posture torque tau_p = Kp0 (q_0 - q) - Kd0 v, and b = ID(q, v, 0) - tau_passive into tau
    double* tp = ws.tp.data();
    chart_difference(model, q, src.qref.data(), tp);
    const double* g = src.gains.data();
    for (int i = 0; i < nv; ++i) tp[i] = g[i] * tp[i] - g[nv + i] * v[i];
    rnea(model, ws.data, q, v, ws.zero.data(), gravity, nullptr, true, true, tau);
    for (int i = 0; i < nv; ++i) tau[i] += tp[i] - tau_passive[i];
    double* JM = ws.JM.data();  // J M^-1 (task rows)
    for (int a = 0; a < r; ++a)
        for (int c = 0; c < nv; ++c) {
            double x = 0.0;
            for (int s = 0; s < nv; ++s) x += J[rows[a] * nv + s] * ws.Minv[static_cast<size_t>(s) * nv + c];
            JM[a * nv + c] = x;
        }
    // task errors (6 rows, world axes) and y = xdd* - Jdot v - J M^-1 tau_p
    Mat3 Rd;
    Vec3 wd;
    orientation_at(src, t, Rd, wd);
    const Vec3 eo = rotation_log(Rd * transpose(T.R));
    const double e[6] = {x_ref[0] - T.p.x, x_ref[1] - T.p.y, x_ref[2] - T.p.z, eo.x, eo.y, eo.z};
    const double xd_d[6] = {x_ref[3], x_ref[4], x_ref[5], wd.x, wd.y, wd.z};
    const double xdd_d[6] = {x_ref[6], x_ref[7], x_ref[8], 0.0, 0.0, 0.0};
    for (int a = 0; a < r; ++a) {
        const int k = rows[a];
        double xd = 0.0, JMtp = 0.0;
        for (int c = 0; c < nv; ++c) {
            xd += J[k * nv + c] * v[c];
            JMtp += JM[a * nv + c] * tp[c];
        }
        ws.y[a] = xdd_d[k] + src.task_gains[1][k] * (xd_d[k] - xd) + src.task_gains[0][k] * e[k] - ws.jdv[k] - JMtp;
    }
    // Lambda = (J M^-1 J^T + d 1)^-1, then tau += J^T Lambda y
    for (int a = 0; a < r; ++a)
        for (int b = 0; b < r; ++b) {
            double x = a == b ? src.damping : 0.0;
            for (int s = 0; s < nv; ++s) x += JM[a * nv + s] * J[rows[b] * nv + s];
            ws.A[6 * a + b] = x;
        }
    const bool ok = spd_inverse(ws.A, r, ws.Lam);
    double big_A = 0.0, big_Lam = 0.0;  // max diag(A) max diag(A^-1) <= cond(A) <= r^2 times it (A SPD)
    for (int a = 0; a < r; ++a) big_A = std::max(big_A, ws.A[7 * a]), big_Lam = std::max(big_Lam, ws.Lam[7 * a]);
    if (!ok || !(big_A * big_Lam <= MAX_CONDITION)) {
        std::fill(tau, tau + nv, std::nan(""));
        return T;
    }
    for (int a = 0; a < r; ++a) {
        double F = 0.0;
        for (int b = 0; b < r; ++b) F += ws.Lam[6 * a + b] * ws.y[b];
        for (int c = 0; c < nv; ++c) tau[c] += J[rows[a] * nv + c] * F;
    }
    return T;
}

}  // namespace core::control
