// The references' interpolation (interpolation.hpp).
#include "interpolation.hpp"

#include <algorithm>

namespace core::control {

int segment(const double* times, int N, double t) {
    int k = static_cast<int>(std::upper_bound(times, times + N, t) - times) - 1;
    return std::min(std::max(k, 0), N - 2);
}

void reference_at(const double* times, int N, const double* table, int m, double t, double* q, double* v, double* a) {
    const int cols = 3 * m;
    if (N == 1 || t <= times[0] || t >= times[N - 1]) {
        const int k = (N == 1 || t <= times[0]) ? 0 : N - 1;
        for (int i = 0; i < m; ++i) q[i] = table[k * cols + i], v[i] = table[k * cols + m + i], a[i] = table[k * cols + 2 * m + i];
        return;
    }
    const int k = segment(times, N, t);
    const double h = times[k + 1] - times[k], s = (t - times[k]) / h;
    const double s2 = s * s, s3 = s2 * s, s4 = s3 * s, s5 = s4 * s;
    const double H[6] = {1 - 10 * s3 + 15 * s4 - 6 * s5, s - 6 * s3 + 8 * s4 - 3 * s5,
                         0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5, 0.5 * s3 - s4 + 0.5 * s5, -4 * s3 + 7 * s4 - 3 * s5,
                         10 * s3 - 15 * s4 + 6 * s5};
    const double D[6] = {-30 * s2 + 60 * s3 - 30 * s4, 1 - 18 * s2 + 32 * s3 - 15 * s4, s - 4.5 * s2 + 6 * s3 - 2.5 * s4,
                         1.5 * s2 - 4 * s3 + 2.5 * s4, -12 * s2 + 28 * s3 - 15 * s4, 30 * s2 - 60 * s3 + 30 * s4};
    const double DD[6] = {-60 * s + 180 * s2 - 120 * s3, -36 * s + 96 * s2 - 60 * s3, 1 - 9 * s + 18 * s2 - 10 * s3,
                          3 * s - 12 * s2 + 10 * s3, -24 * s + 84 * s2 - 60 * s3, 60 * s - 180 * s2 + 120 * s3};
    const double *r0 = table + k * cols, *r1 = table + (k + 1) * cols;
    for (int i = 0; i < m; ++i) {
        const double c[6] = {r0[i], h * r0[m + i], h * h * r0[2 * m + i], h * h * r1[2 * m + i], h * r1[m + i], r1[i]};
        q[i] = H[0] * c[0] + H[1] * c[1] + H[2] * c[2] + H[3] * c[3] + H[4] * c[4] + H[5] * c[5];
        v[i] = (D[0] * c[0] + D[1] * c[1] + D[2] * c[2] + D[3] * c[3] + D[4] * c[4] + D[5] * c[5]) / h;
        a[i] = (DD[0] * c[0] + DD[1] * c[1] + DD[2] * c[2] + DD[3] * c[3] + DD[4] * c[4] + DD[5] * c[5]) / (h * h);
    }
}

}  // namespace core::control
