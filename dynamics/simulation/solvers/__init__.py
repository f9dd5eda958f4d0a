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
problem (:mod:`.interface`).  ``SOLVERS[name]`` is the entry point for one method: it builds the method's
workspace and runs the driver, so a compiled caller of ``solve_rk4`` holds rk4 only (compile only what a
call uses).  ``auto`` is two entry points, its rk45 phase and its radau phase, alternated by :func:`drive_auto`
(:mod:`.auto`): a run that never turns stiff compiles no radau.  Signature:
``solve_<name>(p, z, t0, t_end, out_t, opt, stats, switches) -> status``.
"""

from ..._numba import generic_inline
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


@generic_inline
def solve_euler(p, z, t0, t_end, out_t, opt, stats, switches):
    return solve_fixed(p, euler.Euler(opt.nc), z, t0, t_end, out_t, opt, stats)


@generic_inline
def solve_rk4(p, z, t0, t_end, out_t, opt, stats, switches):
    return solve_fixed(p, rk4.make(z.shape[0]), z, t0, t_end, out_t, opt, stats)


@generic_inline
def solve_rk45(p, z, t0, t_end, out_t, opt, stats, switches):
    return solve_adaptive(p, rk45.make(z.shape[0]), z, t0, t_end, out_t, opt, stats, switches)


@generic_inline
def solve_dop853(p, z, t0, t_end, out_t, opt, stats, switches):
    return solve_adaptive(p, dop853.make(z.shape[0]), z, t0, t_end, out_t, opt, stats, switches)


@generic_inline
def solve_radau(p, z, t0, t_end, out_t, opt, stats, switches):
    return solve_adaptive(p, radau.make(z.shape[0]), z, t0, t_end, out_t, opt, stats, switches)


@generic_inline
def solve_auto_rk45(p, z, t0, t_end, out_t, opt, stats, switches):
    """auto's non-stiff phase: rk45 until its stiffness test fires (status SWITCHED) or t_end."""
    return solve_adaptive(p, auto.make_rk45(z.shape[0]), z, t0, t_end, out_t, opt, stats, switches)


@generic_inline
def solve_auto_radau(p, z, t0, t_end, out_t, opt, stats, switches):
    """auto's stiff phase: radau until the problem has been non-stiff for a while (status SWITCHED) or t_end."""
    return solve_adaptive(p, auto.make_radau(z.shape[0]), z, t0, t_end, out_t, opt, stats, switches)


def drive_auto(phases, p, z, t0, t_end, out_t, opt, stats, switches):
    """``auto`` from Python: ``phases = (entry of solve_auto_rk45, entry of solve_auto_radau)``, compiled callers
    with the solvers' signature; each runs until it asks for the other method (:mod:`.auto`), which resumes from
    the time, state, samples and statistics reached, with the step size the first proposed.  A problem that
    never turns stiff never calls (so never compiles) the radau phase.  Returns the final status."""
    stiff = 0
    while True:
        status = phases[stiff](p, z, t0, t_end, out_t, opt, stats, switches)
        if status != SWITCHED:
            return status
        stiff = 1 - stiff
        t0, opt = float(stats[0]["t"]), opt._replace(h0=float(stats[0]["h"]))


SOLVERS = {"euler": solve_euler, "rk4": solve_rk4, "rk45": solve_rk45, "dop853": solve_dop853,
           "radau": solve_radau, "auto": (solve_auto_rk45, solve_auto_radau)}
