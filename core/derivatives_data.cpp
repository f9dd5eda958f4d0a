// The derivatives' workspace (derivatives_data.hpp).
#include "derivatives_data.hpp"

namespace core {

void DerivativesData::resize(const Model& model) {
    if (nb == model.nb && nv == model.nv) return;
    nb = model.nb, nv = model.nv;
    oM.resize(nb), ov.resize(nb), oa.resize(nb), Y.resize(nb), B.resize(nb), hf.resize(nb), F.resize(nb);
    J.resize(nv), dV.resize(nv), dAq.resize(nv), dAv.resize(nv), Fa.resize(nv), Fv.resize(nv), Fq.resize(nv);
    lv.resize(nv), qdd.resize(nv), K.resize(nv);
    const size_t nn = static_cast<size_t>(nv) * nv;
    dtau_dq.resize(nn + 4), dtau_dv.resize(nn + 4), M.resize(nn);
}

DerivativesData& thread_derivatives_data(const Model& model) {
    thread_local DerivativesData data;
    data.resize(model);
    return data;
}

}  // namespace core
