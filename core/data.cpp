// The workspace, and the forward pass written once (data.hpp).
#include "data.hpp"

#include "joints.hpp"

namespace core {

void Data::resize(const Model& model) {
    if (nb == model.nb && nv == model.nv && nq == model.nq) return;
    nb = model.nb, nv = model.nv, nq = model.nq;
    for (auto* x : {&X, &oMi}) x->resize(nb);
    for (auto* x : {&v, &c, &a}) x->resize(nb);
    f.resize(nb), pA.resize(nb), Ic.resize(nb), g.resize(nb), IA.resize(nb), Dinv.resize(nb);
    path.resize(nb), nsub.resize(nb);
    U.resize(nv), UD.resize(nv), u.resize(nv), Sw.resize(nv);
    J.resize(6 * nv), Jt.resize(6 * nv), Minv.resize(static_cast<size_t>(nv) * nv), JM.resize(6 * nv);
    cols.resize(nv);
    tmp_v.resize(nv), tmp_v2.resize(nv), tmp_q.resize(nq), tmp_q2.resize(nq);
}

Data& thread_data(const Model& model) {
    thread_local Data data;
    data.resize(model);
    return data;
}

void forward_body(const Model& model, Data& data, int i, const double* q, const double* qd, bool with_v) {
    Transform X = joint_transform(model, i, q);
    data.X[i] = X;
    if (!with_v) {
        data.c[i] = Motion{};
        return;
    }
    int par = model.parents[i];
    Motion v = motion_to_child(X, par < 0 ? Motion{} : data.v[par]);
    Motion vJ = joint_motion(model, i, qd);
    v = v + vJ;
    data.v[i] = v;
    data.c[i] = cross(v, vJ);
}

}  // namespace core
