// Spatial algebra: the two routines too long to inline (spatial.hpp has the conventions).
#include "spatial.hpp"

#include <algorithm>

namespace core {

Vec3 rotation_log(const Mat3& R) {
    Vec3 w = {0.5 * (R[7] - R[5]), 0.5 * (R[2] - R[6]), 0.5 * (R[3] - R[1])};  // sin(theta) axis
    double c = std::min(1.0, std::max(-1.0, 0.5 * (R[0] + R[4] + R[8] - 1.0)));  // cos(theta)
    double s = std::sqrt(dot(w, w));
    double theta = std::atan2(s, c);
    if (c > -0.99) {  // theta / sin(theta) is well conditioned (its series near 0)
        double f = s < 1e-8 ? 1.0 + s * s / 6.0 : theta / s;
        return f * w;
    }
    // near pi: the axis from R + R^T = 2 c 1 + 2 (1 - c) a a^T, its largest diagonal entry first
    int k = 0;
    if (R[4] > R[3 * k + k]) k = 1;
    if (R[8] > R[3 * k + k]) k = 2;
    Vec3 a = {(R[k] + R[3 * k]) * 0.5, (R[3 + k] + R[3 * k + 1]) * 0.5, (R[6 + k] + R[3 * k + 2]) * 0.5};
    a = {a.x - (k == 0 ? c : 0.0), a.y - (k == 1 ? c : 0.0), a.z - (k == 2 ? c : 0.0)};
    double n = std::sqrt(dot(a, a));
    if (dot(a, w) < 0.0) n = -n;
    return (theta / n) * a;
}

bool spd_inverse(const double* D, int n, double* Dinv) {
    double A[36];
    for (int r = 0; r < n; ++r)
        for (int c = 0; c < n; ++c) {
            A[6 * r + c] = D[6 * r + c];
            Dinv[6 * r + c] = r == c ? 1.0 : 0.0;
        }
    for (int k = 0; k < n; ++k) {
        double piv = A[6 * k + k];
        if (!(piv > 0.0)) return false;
        double inv = 1.0 / piv;
        for (int c = 0; c < n; ++c) {
            A[6 * k + c] *= inv;
            Dinv[6 * k + c] *= inv;
        }
        for (int r = 0; r < n; ++r) {
            if (r == k) continue;
            double fac = A[6 * r + k];
            if (fac == 0.0) continue;
            for (int c = 0; c < n; ++c) {
                A[6 * r + c] -= fac * A[6 * k + c];
                Dinv[6 * r + c] -= fac * Dinv[6 * k + c];
            }
        }
    }
    return true;
}

}  // namespace core
