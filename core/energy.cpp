// Kinetic and potential energy (energy.hpp has the equations).
#include "energy.hpp"

#include <cmath>
#include <new>

namespace core {

namespace {

// dst = src component by component.  A copy of the whole struct was compiled into a spill of other widths than the
// loads that read it back (a store-forwarding stall per body, a fifth of the function's time in perf annotate).
inline void store(Motion& dst, const Motion& src) {
    dst.w.x = src.w.x, dst.w.y = src.w.y, dst.w.z = src.w.z;
    dst.v.x = src.v.x, dst.v.y = src.v.y, dst.v.z = src.v.z;
}

}  // namespace

// One loop over the bodies: each body's transform, its velocity (kinetic) and world pose (potential), and its terms;
// the forward pass's arithmetic (forward_body) without its velocity-product accelerations, which the energies do
// not read (a simulation's samples call this once each).
void energies(const Model& model, Data& data, const double* q, const double* v, const Vec3& gravity, bool kinetic,
              bool potential, double& T, double& U) {
    T = 0.0, U = 0.0;
    revolute_sines(model, data, q);  // first (data.hpp)
    for (int i = 0; i < model.nb; ++i) {
        const Inertia& I = model.I[i];
        const int par = model.parents[i];
        // joint_transform(model, i, q), its revolute case written here (the compiler keeps joint_transform out of
        // line, its result returned through memory); the others constructed in place in data.X[i]
        Transform& X = data.X[i];
        if (model.jtype[i] == JOINT_REVOLUTE) {
            X.R = rodrigues(model, i, data.sin_q[i], data.vers_q[i]);
            X.p = model.Xpos[i];
        } else {
            new (&X) Transform(joint_transform(model, i, q));
        }
        if (kinetic) {
            const Motion vi = motion_to_child(X, par < 0 ? Motion{} : data.v[par]) + joint_motion(model, i, v);
            store(data.v[i], vi);
            const Force h = I * vi;
            T += 0.5 * (dot(vi.w, h.n) + dot(vi.v, h.f));
        }
        if (potential) {
            const Transform oM = par < 0 ? X : compose(data.oMi[par], X);
            data.oMi[i] = oM;
            U -= I.m * dot(gravity, oM.p) + dot(gravity, rot(oM.R, I.h));  // m g . (p + R c)
        }
    }
}

}  // namespace core
