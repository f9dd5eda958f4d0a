// M^-1 in O(n^2) (minverse.hpp has the equations): the world pass here, the backward and forward passes in
// minverse_passes.cpp (which the fused ABA derivatives run after a world pass of their own).
#include "minverse.hpp"

#include "aba.hpp"
#include "joints.hpp"
#include "kinematics.hpp"
#include "minverse_passes.hpp"

namespace core {

int inverse_mass_matrix(const Model& model, Data& d, const double* q, double* Minv) {
    const int nb = model.nb;
    for (int i = 0; i < nb; ++i) {  // world poses, motion axes and inertias
        world_pose(model, d, i, q);
        const Transform& oM = d.oMi[i];
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) {
            const Vec3 w = rot(oM.R, model.S[k].w);
            d.Sw[k] = {w, rot(oM.R, model.S[k].v) + cross(oM.p, w)};
        }
        d.IA[i] = to_matrix(inertia_to_parent(oM, model.I[i]));  // about the world origin
        d.nsub[i] = model.nv_j[i];
    }
    for (int i = nb - 1; i >= 0; --i)
        if (model.parents[i] >= 0) d.nsub[model.parents[i]] += d.nsub[i];
    const int singular = minverse_backward_pass(model, d, Minv);  // minverse_passes.cpp
    if (singular >= 0) return singular;
    minverse_forward_pass(model, d, Minv);
    return -1;
}

}  // namespace core
