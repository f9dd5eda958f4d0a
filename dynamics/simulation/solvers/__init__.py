"""ODE solvers for y' = f(t, y), one file per method, and two drivers.

==========  ==================  ============================================================================
method      file                what it is
==========  ==================  ============================================================================
euler       :mod:`.euler`       semi-implicit (symplectic) Euler, fixed step, order 1
rk4         :mod:`.rk4`         classical Runge-Kutta, fixed step, order 4, Hermite samples
rk45        :mod:`.rk45`        Dormand-Prince 5(4), PI control, quartic dense output, stiffness test
dop853      :mod:`.dop853`      Hairer's DOP853, 7th-order dense output
radau       :mod:`.radau`       Radau IIA(5), simplified Newton, Gustafsson's controller
auto        :mod:`.auto`        rk45 <-> radau on the stiffness test and the spectral radius
==========  ==================  ============================================================================

:func:`~.fixed.solve_fixed` and :func:`~.adaptive.solve_adaptive` drive any method of their kind over any
problem (:mod:`.interface`), given the method's stepper (``rk4.make(n)``, ``auto.make_rk45(n)``, ...): a
compiled caller that passes one stepper holds that method only (compile only what a call uses;
:mod:`dynamics.simulation.run` has one entry point per method).  ``auto`` is two entry points, its rk45 phase
and its radau phase, alternated by :func:`drive_auto` (:mod:`.auto`): a run that never turns stiff compiles no
radau.  Signatures: ``solve_fixed(p, stepper, z, t0, t_end, out_t, opt, stats)`` and
``solve_adaptive(p, stepper, z, t0, t_end, out_t, opt, stats, switches)``, each returning the status.
"""

from . import auto, dop853, euler, radau, rk4, rk45
from .adaptive import solve_adaptive
from .fixed import solve_fixed
from .interface import (MAX_SWITCHES, NONFINITE, OK, RADAU, RK45, STATS, STATUS_NAMES, SWITCH, SWITCH_CONTACT,
                        SWITCH_NONSTIFF, SWITCH_STIFF, SWITCHED, Options, new_stats, new_switch_log)

FIXED = ("euler", "rk4")
ADAPTIVE = ("rk45", "dop853", "radau", "auto")
ORDER = {"euler": euler.ORDER, "rk4": rk4.ORDER}
#: stability limits of the explicit methods along the negative real axis (|h lambda| <= limit)
STABILITY_LIMIT = {"euler": euler.STABILITY_LIMIT, "rk4": rk4.STABILITY_LIMIT, "rk45": rk45.STABILITY_LIMIT}


def drive_auto(phases, p, z, t0, t_end, out_t, opt, stats, switches):
    """``auto`` from Python: ``phases = (entry of its rk45 phase, entry of its radau phase)``, compiled callers
    taking (p, z, t0, t_end, out_t, opt, stats, switches); each runs until it asks for the other method (:mod:`.auto`), which resumes from
    the time, state, samples and statistics reached, with the step size the first proposed.  A problem that
    never turns stiff never calls (so never compiles) the radau phase.  Returns the final status."""
    stiff = 0
    while True:
        status = phases[stiff](p, z, t0, t_end, out_t, opt, stats, switches)
        if status != SWITCHED:
            return status
        stiff = 1 - stiff
        t0, opt = float(stats[0]["t"]), opt._replace(h0=float(stats[0]["h"]))

