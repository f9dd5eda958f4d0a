// J M^-1 J^T over the frame's support columns (task_space.hpp).
#include "task_space.hpp"

#include <algorithm>

#include "jacobians.hpp"
#include "kinematics.hpp"
#include "minverse.hpp"

namespace core {

int jminvjt(const Model& model, Data& data, const double* q, int f, int ref, const int* rows, int r, double* JMJ) {
    const int nv = model.nv;
    std::vector<double>&J = data.J, &Minv = data.Minv, &JM = data.JM;
    std::vector<int>& cols = data.cols;
    std::fill(J.begin(), J.end(), 0.0);
    int n = 0;  // the support's columns: J is zero elsewhere
    const int depth = support(model, data, model.frame_body[f]);
    for (int t = 0; t < depth; ++t)
        for (int k = model.v_idx[data.path[t]]; k < model.v_idx[data.path[t]] + model.nv_j[data.path[t]]; ++k)
            cols[n++] = k;
    frame_jacobian(model, data, q, f, ref, {}, J.data());
    const int singular = inverse_mass_matrix(model, data, q, Minv.data());
    for (int a = 0; a < r; ++a)
        for (int c = 0; c < n; ++c) {
            double x = 0.0;
            for (int t = 0; t < n; ++t) x += J[rows[a] * nv + cols[t]] * Minv[static_cast<size_t>(cols[t]) * nv + cols[c]];
            JM[static_cast<size_t>(a) * nv + c] = x;
        }
    for (int a = 0; a < r; ++a)
        for (int e = 0; e < r; ++e) {
            double x = 0.0;
            for (int t = 0; t < n; ++t) x += JM[static_cast<size_t>(a) * nv + t] * J[rows[e] * nv + cols[t]];
            JMJ[a * r + e] = x;
        }
    return singular;
}

}  // namespace core
