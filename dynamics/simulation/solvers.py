"""The solvers' vocabulary on the Python side: the methods, the options a run takes, the statistics and switch
records the core writes (``core/simulation/solver.hpp``: the same field order and types), and the statuses.

==========  =================================================================================================
method      what it is (``core/simulation/<method>.cpp``)
==========  =================================================================================================
euler       semi-implicit (symplectic) Euler, fixed step, order 1
implicit_euler  symplectic Euler with the stiff forces (contact, passive, PD) linearly implicit, fixed step, order 1
rk4         classical Runge-Kutta, fixed step, order 4, Hermite samples
rk45        Dormand-Prince 5(4), PI control, quartic dense output, stiffness test
dop853      Hairer's DOP853, 7th-order dense output
radau       Radau IIA(5), simplified Newton, Gustafsson's controller
auto        rk45 <-> radau on the stiffness test, the spectral radius and contact touch-downs
==========  =================================================================================================

State layout of a run: z = [configuration part (nc), velocity part (nvel), quadratures]; only the first ``ne``
components enter the error norms and Newton's convergence test.
"""

from typing import NamedTuple

import numpy as np

FIXED = ("euler", "implicit_euler", "rk4")
ADAPTIVE = ("rk45", "dop853", "radau", "auto")
ORDER = {"euler": 1, "implicit_euler": 1, "rk4": 4}
#: stability limits of the explicit methods along the negative real axis (|h lambda| <= limit); implicit_euler has
#: none for the forces it treats implicitly
STABILITY_LIMIT = {"euler": 2.0, "rk4": 2.785, "rk45": 3.3}

OK, NONFINITE, BLOWUP, MAX_STEPS, STEP_TOO_SMALL, SWITCHED = 0, 1, 2, 3, 4, 5
#: SWITCHED is never a run's final status: ``auto`` resumes with its other method
STATUS_NAMES = ("ok", "nonfinite", "blowup", "max_steps", "step_too_small", "switched")

RK45, RADAU = 0, 1  # what the auto switch logs in ``Switch.to``
SWITCH_STIFF, SWITCH_NONSTIFF, SWITCH_CONTACT = 0, 1, 2  # switch reasons
MAX_SWITCHES = 64


class Options(NamedTuple):
    """What a solver is asked to do (``core::sim::Options``)."""

    nc: int  # configuration (chart) components of z
    nvel: int  # velocity components (checked against ``blowup``)
    ne: int  # components under error control (the rest are quadratures)
    max_steps: int  # budget of attempted steps (adaptive)
    nsteps: int  # number of steps (fixed-step methods)
    dt: float  # step (fixed-step methods)
    rtol: float
    atol: float
    h0: float  # first step (adaptive; <= 0: Hairer's starting-step heuristic)
    hmax: float
    blowup: float  # a velocity above this stops the run
    probe: int  # fixed-step methods: 1 = first estimate the spectral radius of df/dz at t0 (stats.rho0)


#: statistics, one record written by the core (``np.zeros(1, STATS)``; ``core::sim::Stats``)
STATS = np.dtype([
    ("status", np.int64), ("steps", np.int64), ("rejected", np.int64), ("rhs_evals", np.int64),
    ("jacobian_evals", np.int64), ("lu_decompositions", np.int64), ("switches", np.int64),
    ("stiff_hits", np.int64),
    ("samples", np.int64),  # output samples written: a resumed run (``auto``'s other method) goes on from here
    ("switch_request", np.int64),  # set by an ``auto`` stepper: end the run after this step (status SWITCHED)
    ("t", np.float64),  # time reached
    ("h", np.float64),  # last step size
    ("local_error", np.float64),  # sum over accepted steps of the max-norm of the local error estimates
    ("stiff_t", np.float64),  # rk45: when the stiffness test first fired (NaN: never)
    ("h_rho", np.float64),  # radau: largest h * spectral radius seen (NaN: none)
    ("rho0", np.float64),  # spectral radius of df/dz at t0 when Options.probe asked for it (NaN: not asked)
], align=True)

#: one switch of ``auto``: time, method switched to (RK45 or RADAU), reason, the measured h*|lambda|
SWITCH = np.dtype([("t", np.float64), ("to", np.int64), ("reason", np.int64), ("value", np.float64)], align=True)


def new_stats():
    st = np.zeros(1, STATS)
    st["t"] = st["h"] = st["stiff_t"] = st["h_rho"] = st["rho0"] = np.nan
    return st


def new_switch_log():
    return np.zeros(MAX_SWITCHES, SWITCH)
