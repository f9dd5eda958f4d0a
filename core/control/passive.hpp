// The passive joint torques the simulator always adds (the laws are in dynamics/torques.py's docstring): viscous
// damping, regularised Coulomb friction and, with limits, a Hunt-Crossley spring-damper at the position limits.
//     tau_k = -b_k v_k - mu_k tanh(v_k / eps)
//             + max(0, k (lower - x) - b_l (lower - x) v_k)    below the lower limit (x = q of the 1-dof joint)
//             - max(0, k (x - upper) + b_l (x - upper) v_k)    above the upper limit
#pragma once

#include <vector>

#include "spatial.hpp"

namespace core::control {

struct Passive {
    std::vector<double> damping, friction;  // (nv,)
    double friction_eps = 1e-3;
    bool limits = false;                  // the limit springs
    std::vector<double> lower, upper;     // (nv,)
    std::vector<int> qpos;                // (nv,): q index of a 1-dof coordinate, -1 for the others
    double k_limit = 1e4, b_limit = 100.0;
    Vec3 gravity;
};

// out (nv) = the passive torques at (q, v).
void passive_torques(const Passive& ps, const double* q, const double* v, int nv, double* out);
// The diagonals of d tau_passive/dq (1-dof coordinates; zero for the others) and d tau_passive/dv.
void passive_derivatives(const Passive& ps, const double* q, const double* v, int nv, double* dq, double* dv);

}  // namespace core::control
