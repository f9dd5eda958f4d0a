// The configuration manifold: every function loops over the joints (configuration.hpp).
#include "configuration.hpp"

#include "joints.hpp"

namespace core {

void integrate(const Model& model, const double* q, const double* v, double dt, double* delta, double* out) {
    integrate_delta(model, q, v, dt, delta);
    retract(model, q, delta, out);
}

void difference(const Model& model, const double* q0, const double* q1, double* out) {
    for (int i = 0; i < model.nb; ++i) joint_log(model, i, q0, q1, out);
}

void retract(const Model& model, const double* q0, const double* delta, double* q) {
    if (!model.has_unit_blocks) {  // 1-dof joints only: q = q0 + delta
        for (int i = 0; i < model.nb; ++i) q[model.q_idx[i]] = q0[model.q_idx[i]] + delta[model.v_idx[i]];
        return;
    }
    for (int i = 0; i < model.nb; ++i) joint_retract(model, i, q0, delta, q);
}

void chart_rate(const Model& model, const double* q, const double* delta, const double* v, double* out) {
    if (!model.has_unit_blocks) {  // 1-dof joints only: delta' = v
        for (int k = 0; k < model.nv; ++k) out[k] = v[k];
        return;
    }
    for (int i = 0; i < model.nb; ++i) joint_chart_rate(model, i, q, delta, v, out);
}

void integrate_delta(const Model& model, const double* q, const double* v, double dt, double* delta) {
    for (int i = 0; i < model.nb; ++i) joint_integrate_delta(model, i, q, v, dt, delta);
}

void magnitudes(const Model& model, const double* q, double* mag) {
    for (int i = 0; i < model.nb; ++i) joint_magnitudes(model, i, q, mag);
}

void chart_difference(const Model& model, const double* q0, const double* q1, double* out) {
    for (int i = 0; i < model.nb; ++i) joint_difference(model, i, q0, q1, out);
}

}  // namespace core
