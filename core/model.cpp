// The model's consistency check: after it, every index an algorithm reads is in bounds.
#include "model.hpp"

#include <stdexcept>
#include <string>

#include "joints.hpp"

namespace core {

static void require(bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("model: " + what);
}

static void require_size(size_t got, long want, const char* name) {
    require(got == static_cast<size_t>(want),
            std::string(name) + " has " + std::to_string(got) + " entries, expected " + std::to_string(want));
}

// k when joint i is revolute with S_i = (e_k, 0) exactly (k in {0, 1, 2}), else -1 (Model::axis_k).
static int revolute_axis_index(const Model& m, int i) {
    if (m.jtype[i] != JOINT_REVOLUTE) return -1;
    const Motion& s = m.S[m.v_idx[i]];
    if (s.v.x != 0.0 || s.v.y != 0.0 || s.v.z != 0.0) return -1;
    const double w[3] = {s.w.x, s.w.y, s.w.z};
    for (int k = 0; k < 3; ++k)
        if (w[k] == 1.0 && w[(k + 1) % 3] == 0.0 && w[(k + 2) % 3] == 0.0) return k;
    return -1;
}

void dof_parents(const Model& model, int* lam) {
    for (int i = 0; i < model.nb; ++i) {
        const int p = model.parents[i];
        int prev = p >= 0 ? model.v_idx[p] + model.nv_j[p] - 1 : -1;
        for (int k = model.v_idx[i]; k < model.v_idx[i] + model.nv_j[i]; ++k) lam[k] = prev, prev = k;
    }
}

void check(Model& m) {
    require(m.nb >= 0 && m.nq >= 0 && m.nv >= 0, "negative sizes");
    for (auto* a : {&m.parents, &m.jtype, &m.q_idx, &m.v_idx, &m.nv_j}) require_size(a->size(), m.nb, "a per-body array");
    require_size(m.Xrot.size(), m.nb, "Xrot");
    require_size(m.XK.size(), m.nb, "XK");
    require_size(m.XKK.size(), m.nb, "XKK");
    require_size(m.Xpos.size(), m.nb, "Xpos");
    require_size(m.axis.size(), m.nb, "axis");
    require_size(m.I.size(), m.nb, "inertias");
    require_size(m.S.size(), m.nv, "S");
    require_size(m.lower.size(), m.nv, "lower");
    require_size(m.upper.size(), m.nv, "upper");
    int nq = 0, nv = 0;
    m.has_unit_blocks = false;
    for (int i = 0; i < m.nb; ++i) {
        require(m.parents[i] >= -1 && m.parents[i] < i, "body " + std::to_string(i) + ": parent must be in [-1, i)");
        int t = m.jtype[i];
        require(t >= 0 && t < JOINT_TYPES, "body " + std::to_string(i) + ": unknown joint type " + std::to_string(t));
        require(m.q_idx[i] == nq && m.v_idx[i] == nv && m.nv_j[i] == joint_nv(t),
                "body " + std::to_string(i) + ": q_idx, v_idx or nv_j do not follow the joint types");
        nq += joint_nq(t);
        nv += joint_nv(t);
        m.has_unit_blocks = m.has_unit_blocks || joint_nq(t) != joint_nv(t);
    }
    require(nq == m.nq && nv == m.nv, "nq or nv is not the sum of the joints'");
    m.axis_k.assign(m.nb, -1);
    for (int i = 0; i < m.nb; ++i) m.axis_k[i] = revolute_axis_index(m, i);
    for (auto* a : {&m.frame_body, &m.frame_kind}) require_size(a->size(), m.nf, "a per-frame array");
    require_size(m.frame_R.size(), m.nf, "frame_R");
    require_size(m.frame_p.size(), m.nf, "frame_p");
    for (int f = 0; f < m.nf; ++f) {
        require(m.frame_body[f] >= -1 && m.frame_body[f] < m.nb, "frame " + std::to_string(f) + ": body out of range");
        int kind = m.frame_kind[f];
        require(kind >= FRAME_BODY && kind <= FRAME_WORLD && (kind == FRAME_WORLD) == (m.frame_body[f] < 0),
                "frame " + std::to_string(f) + ": kind does not match its body");
    }
}

}  // namespace core
