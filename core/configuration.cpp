// The configuration manifold: every function loops over the joints (configuration.hpp).
#include "configuration.hpp"

#include "joints.hpp"

namespace core {

void integrate(const Model& model, const double* q, const double* v, double dt, double* delta, double* out) {
    for (int i = 0; i < model.nb; ++i) joint_integrate_delta(model, i, q, v, dt, delta);
    retract(model, q, delta, out);
}

void difference(const Model& model, const double* q0, const double* q1, double* out) {
    for (int i = 0; i < model.nb; ++i) joint_log(model, i, q0, q1, out);
}

void retract(const Model& model, const double* q0, const double* delta, double* q) {
    for (int i = 0; i < model.nb; ++i) joint_retract(model, i, q0, delta, q);
}

void chart_difference(const Model& model, const double* q0, const double* q1, double* out) {
    for (int i = 0; i < model.nb; ++i) joint_difference(model, i, q0, q1, out);
}

}  // namespace core
