// The extension module dynamics._core: the C++ core (core/) bound for the Python package, one file per area.
#include "arrays.hpp"
#include "numpy.hpp"

namespace bind {
void expose_model(nb::module_& m);
void expose_dynamics(nb::module_& m);
void expose_kinematics(nb::module_& m);
void expose_configuration(nb::module_& m);
void expose_simulation(nb::module_& m);
void expose_simulator(nb::module_& m);
void expose_derivatives(nb::module_& m);
void expose_constraints(nb::module_& m);
void expose_contact_model(nb::module_& m);
void expose_contact(nb::module_& m);
void expose_ode(nb::module_& m);
void expose_control(nb::module_& m);
}  // namespace bind

NB_MODULE(_core, m) {
    m.doc() = "The compiled core of dynamics (internal: call the functions of the dynamics package).";
    bind::import_numpy();
    bind::expose_model(m);
    bind::expose_dynamics(m);
    bind::expose_kinematics(m);
    bind::expose_configuration(m);
    bind::expose_simulation(m);
    bind::expose_simulator(m);
    bind::expose_derivatives(m);
    bind::expose_constraints(m);
    bind::expose_contact_model(m);
    bind::expose_contact(m);
    bind::expose_ode(m);
    bind::expose_control(m);
}
