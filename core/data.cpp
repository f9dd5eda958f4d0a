// The workspace, and the forward pass written once (data.hpp).
#include "data.hpp"

namespace core {

void Data::resize(const Model& model) {
    if (nb == model.nb && nv == model.nv && nq == model.nq) return;
    nb = model.nb, nv = model.nv, nq = model.nq;
    for (auto* x : {&X, &oMi}) x->resize(nb);
    for (auto* x : {&v, &c, &a}) x->resize(nb);
    f.resize(nb), pA.resize(nb), Ic.resize(nb), g.resize(nb), IA.resize(nb), Dinv.resize(nb);
    path.resize(nb), nsub.resize(nb), sin_q.resize(nb), vers_q.resize(nb);
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

}  // namespace core
