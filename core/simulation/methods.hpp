// The methods, one file each (euler.cpp, implicit_euler.cpp, rk4.cpp, rk45.cpp, dop853.cpp, radau.cpp, auto.cpp):
// each its tableau, one attempted step and its dense output, as scipy's _ivp and Drake's integrators are laid out.
#pragma once

#include <memory>

#include "solver.hpp"

namespace core::sim {

constexpr int RK45_ORDER = 5, RADAU_ORDER = 3, DOP853_ORDER = 8, EULER_ORDER = 1, RK4_ORDER = 4,
              IMPLICIT_EULER_ORDER = 1;
// |h lambda| on the negative real axis beyond which the explicit methods are unstable
constexpr double EULER_STABILITY = 2.0, RK4_STABILITY = 2.785, RK45_STABILITY = 3.3;

std::unique_ptr<FixedStepper> make_euler(int nc, int n);
std::unique_ptr<FixedStepper> make_rk4(int n);
// nv: the velocity components z[nc, nc + nv) (nc = nv for the robot's chart)
std::unique_ptr<FixedStepper> make_implicit_euler(int nc, int n);
std::unique_ptr<AdaptiveStepper> make_rk45(int n);
std::unique_ptr<AdaptiveStepper> make_dop853(int n);
std::unique_ptr<AdaptiveStepper> make_radau(int n);
// auto's two phases: rk45 asking for radau when its stiffness test fires or a state touches something after
// touching nothing; radau asking for rk45 after 20 accepted steps in a row with h rho < 2 (auto.cpp).
std::unique_ptr<AdaptiveStepper> make_auto_rk45(int n);
std::unique_ptr<AdaptiveStepper> make_auto_radau(int n);

}  // namespace core::sim
