// The mass matrix by the CRBA (crba.hpp has the equations).
#include "crba.hpp"

#include "cpu_dispatch.hpp"
#include "joints.hpp"

namespace core {

namespace {

// The composite inertias and M from data.X.
ALWAYS_INLINE void composite_pass(const Model& model, Data& data, double* M) {
    const int nv = model.nv;
    for (int i = 0; i < model.nb; ++i) data.Ic[i] = model.I[i];
    for (int i = model.nb - 1; i >= 0; --i) {
        const Inertia Ic = data.Ic[i];
        const int par = model.parents[i];
        if (par >= 0) {  // I^c_parent += X^T I^c_i X
            Inertia P = inertia_to_parent(data.X[i], Ic);
            Inertia& Ip = data.Ic[par];
            Ip.m += Ic.m;
            Ip.h = Ip.h + P.h;
            Ip.Io = Ip.Io + P.Io;
        }
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            Force F = Ic * model.S[k];
            for (int j = i;;) {  // M[k, dofs(j)] = S_j^T F for j = i and its ancestors
                for (int c = model.v_idx[j]; c < model.v_idx[j] + model.nv_j[j] && c <= k; ++c) {
                    double x = dot(model.S[c], F);
                    M[k * nv + c] = x;
                    M[c * nv + k] = x;
                }
                const int pj = model.parents[j];
                if (pj < 0) break;
                F = force_to_parent(data.X[j], F);
                j = pj;
            }
        }
    }
}

}  // namespace

// Compiled three times, portable, AVX2 and AVX-512F (no fused multiply-add: the same bits), as rnea() is
// (cpu_dispatch.hpp).
AVX512_CLONE FLATTEN void crba(const Model& model, Data& data, const double* q, double* M) {
    for (int i = 0; i < model.nb; ++i) data.X[i] = joint_transform(model, i, q);
    composite_pass(model, data, M);
}

AVX512_CLONE FLATTEN void crba_from_placements(const Model& model, Data& data, double* M) {
    composite_pass(model, data, M);
}

}  // namespace core
