// Kinetic and potential energy (energy.hpp has the equations).
#include "energy.hpp"

namespace core {

void energies(const Model& model, Data& data, const double* q, const double* v, const Vec3& gravity, bool kinetic,
              bool potential, double& T, double& U) {
    forward_pass(model, data, q, v, kinetic);
    T = 0.0, U = 0.0;
    for (int i = 0; i < model.nb; ++i) {
        const Inertia& I = model.I[i];
        if (kinetic) {
            const Motion& vi = data.v[i];
            const Force h = I * vi;
            T += 0.5 * (dot(vi.w, h.n) + dot(vi.v, h.f));
        }
        if (potential) {
            const int par = model.parents[i];
            const Transform oM = par < 0 ? data.X[i] : compose(data.oMi[par], data.X[i]);
            data.oMi[i] = oM;
            U -= I.m * dot(gravity, oM.p) + dot(gravity, rot(oM.R, I.h));  // m g . (p + R c)
        }
    }
}

}  // namespace core
