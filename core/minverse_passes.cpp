// M^-1's two passes over a caller's world axes and inertias (minverse_passes.hpp): minverse.cpp's steps, copied
// operation for operation so that the bits are inverse_mass_matrix()'s.  1-dof joints take loops with their
// 6-vectors in locals; the others the general ones.
#include "minverse_passes.hpp"

#include "cpu_dispatch.hpp"

namespace core {

namespace {

struct Six {  // a 6-vector as six numbers, core order
    double x[6];
};
Six six(const Motion& m) {
    Six s;
    to_array(m, s.x);
    return s;
}
[[maybe_unused]] Six six(const Force& f) {
    Six s;
    to_array(f, s.x);
    return s;
}

// The backward pass at a 1-dof joint: U = I^A s, D = s . U, its row of M^-1, F_p and I^A_p.
ALWAYS_INLINE bool backward_1dof(const Model& model, Data& d, double* Minv, int i, int k0, int ns, int par) {
    const int nv = model.nv;
    const Six s = six(d.Sw[k0]);
    const Mat6& IA = d.IA[i];
    double u[6];
    for (int r = 0; r < 6; ++r)
        u[r] = IA(r, 0) * s.x[0] + IA(r, 1) * s.x[1] + IA(r, 2) * s.x[2] + IA(r, 3) * s.x[3] + IA(r, 4) * s.x[4] +
               IA(r, 5) * s.x[5];
    d.U[k0] = force_from(u);
    const double D = s.x[0] * u[0] + s.x[1] * u[1] + s.x[2] * u[2] + s.x[3] * u[3] + s.x[4] * u[4] + s.x[5] * u[5];
    if (!(D > 0.0)) return false;
    const double dinv = 1.0 / D;
    d.Dinv[i](0, 0) = dinv;
    double ud[6];
    for (int r = 0; r < 6; ++r) ud[r] = u[r] * dinv;
    d.UD[k0] = force_from(ud);
    double* F = d.F.data();
    auto Fat = [&](int b, int c) { return F + (static_cast<long>(b) * nv + c) * 6; };
    Minv[k0 * nv + k0] = dinv;
    if (par >= 0)  // F_i is zero at i's own column
        for (int r = 0; r < 6; ++r) Fat(par, k0)[r] = u[r] * dinv;
    for (int c = k0 + 1; c < k0 + ns; ++c) {
        const double* f = Fat(i, c);
        const double x = -dinv * (s.x[0] * f[0] + s.x[1] * f[1] + s.x[2] * f[2] + s.x[3] * f[3] + s.x[4] * f[4] +
                                  s.x[5] * f[5]);
        Minv[k0 * nv + c] = x;
        if (par >= 0) {
            double* fp = Fat(par, c);
            for (int r = 0; r < 6; ++r) fp[r] = f[r] + u[r] * x;
        }
    }
    if (par >= 0) {  // I^A_p += I^A - U U^T / D
        Mat6& IAp = d.IA[par];
        for (int r = 0; r < 6; ++r) {
            const double x = ud[r];
            for (int c = 0; c < 6; ++c) IAp(r, c) += IA(r, c) - x * u[c];
        }
    }
    return true;
}

// The backward pass at a joint of nj > 1 coordinates.
ALWAYS_INLINE bool backward_joint(const Model& model, Data& d, double* Minv, int i, int k0, int nj, int ns, int par) {
    const int nv = model.nv;
    const Mat6& IA = d.IA[i];
    double U[6][6], UD[6][6], S[6][6], D[36], scratch[6];
    for (int a = 0; a < nj; ++a) {
        to_array(d.Sw[k0 + a], S[a]);
        for (int r = 0; r < 6; ++r) {
            double x = 0.0;
            for (int c = 0; c < 6; ++c) x += IA(r, c) * S[a][c];
            U[a][r] = x;
        }
        d.U[k0 + a] = force_from(U[a]);
    }
    for (int a = 0; a < nj; ++a)  // D = S^T U
        for (int b = 0; b < nj; ++b) {
            double x = 0.0;
            for (int r = 0; r < 6; ++r) x += S[a][r] * U[b][r];
            D[6 * a + b] = x;
        }
    double* Dinv = d.Dinv[i].a;
    if (!spd_inverse(D, nj, Dinv)) return false;
    for (int a = 0; a < nj; ++a) {
        for (int r = 0; r < 6; ++r) {
            double x = 0.0;
            for (int b = 0; b < nj; ++b) x += U[b][r] * Dinv[6 * b + a];
            UD[a][r] = x;
        }
        d.UD[k0 + a] = force_from(UD[a]);
    }
    double* F = d.F.data();
    auto Fat = [&](int b, int c) { return F + (static_cast<long>(b) * nv + c) * 6; };
    for (int c = k0; c < k0 + ns; ++c) {  // M^-1[i, sub(i)] = D^-1 (E - S^T F_i)
        const bool own = c < k0 + nj;
        for (int b = 0; b < nj; ++b) {
            double x = c == k0 + b ? 1.0 : 0.0;
            if (!own)
                for (int r = 0; r < 6; ++r) x -= S[b][r] * Fat(i, c)[r];
            scratch[b] = x;
        }
        for (int a = 0; a < nj; ++a) {
            double x = 0.0;
            for (int b = 0; b < nj; ++b) x += Dinv[6 * a + b] * scratch[b];
            Minv[(k0 + a) * nv + c] = x;
        }
    }
    if (par < 0) return true;
    for (int c = k0; c < k0 + ns; ++c) {  // F_p = F_i + U M^-1[i, sub(i)] on sub(i)
        const bool own = c < k0 + nj;
        for (int r = 0; r < 6; ++r) {
            double x = own ? 0.0 : Fat(i, c)[r];
            for (int a = 0; a < nj; ++a) x += U[a][r] * Minv[(k0 + a) * nv + c];
            Fat(par, c)[r] = x;
        }
    }
    Mat6& IAp = d.IA[par];  // I^A_p += I^A - U D^-1 U^T
    for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) {
            double x = IA(r, c);
            for (int a = 0; a < nj; ++a) x -= UD[a][r] * U[a][c];
            IAp(r, c) += x;
        }
    return true;
}

// The forward pass at body i (its parent done): its rows of M^-1 from column k0 on, and A_i if it has children.
ALWAYS_INLINE void forward_joint(const Model& model, Data& d, double* Minv, int i, int k0, int nj, int ns, int par) {
    const int nv = model.nv;
    double* A = d.F.data();  // F is spent: its memory holds the accelerations A_i
    auto Aat = [&](int b, int c) { return A + (static_cast<long>(b) * nv + c) * 6; };
    double S[6][6], UD[6][6];
    for (int a = 0; a < nj; ++a) to_array(d.Sw[k0 + a], S[a]), to_array(d.UD[k0 + a], UD[a]);
    const bool children = ns > nj;
    for (int c = k0; c < nv; ++c) {
        if (nj == 1) {
            double x = c < k0 + ns ? Minv[k0 * nv + c] : 0.0;
            double a[6] = {0, 0, 0, 0, 0, 0};
            if (par >= 0) {
                const double* ap = Aat(par, c);
                for (int r = 0; r < 6; ++r) a[r] = ap[r];
                x -= UD[0][0] * a[0] + UD[0][1] * a[1] + UD[0][2] * a[2] + UD[0][3] * a[3] + UD[0][4] * a[4] +
                     UD[0][5] * a[5];
            }
            Minv[k0 * nv + c] = x;
            if (children)
                for (int r = 0; r < 6; ++r) Aat(i, c)[r] = a[r] + S[0][r] * x;
            continue;
        }
        for (int a = 0; a < nj; ++a) {
            double x = c < k0 + ns ? Minv[(k0 + a) * nv + c] : 0.0;
            if (par >= 0)
                for (int r = 0; r < 6; ++r) x -= UD[a][r] * Aat(par, c)[r];
            Minv[(k0 + a) * nv + c] = x;
        }
        if (children)
            for (int r = 0; r < 6; ++r) {
                double x = par >= 0 ? Aat(par, c)[r] : 0.0;
                for (int a = 0; a < nj; ++a) x += S[a][r] * Minv[(k0 + a) * nv + c];
                Aat(i, c)[r] = x;
            }
    }
}

}  // namespace

AVX2_CLONE int minverse_backward_pass(const Model& model, Data& d, double* Minv) {
    d.F.resize(static_cast<size_t>(model.nb) * model.nv * 6);
    for (int i = model.nb - 1; i >= 0; --i) {
        const int k0 = model.v_idx[i], nj = model.nv_j[i];
        const bool ok = nj == 1 ? backward_1dof(model, d, Minv, i, k0, d.nsub[i], model.parents[i])
                                : backward_joint(model, d, Minv, i, k0, nj, d.nsub[i], model.parents[i]);
        if (!ok) return i;
    }
    return -1;
}

AVX2_CLONE void minverse_forward_pass(const Model& model, Data& d, double* Minv) {
    const int nv = model.nv;
    for (int i = 0; i < model.nb; ++i)  // columns c >= k0
        forward_joint(model, d, Minv, i, model.v_idx[i], model.nv_j[i], d.nsub[i], model.parents[i]);
    for (int r = 0; r < nv; ++r)
        for (int c = r + 1; c < nv; ++c) Minv[c * nv + r] = Minv[r * nv + c];
}

}  // namespace core
