"""What the solvers and the problem say to each other: the problem interface, the stepper interface, the
named options and statistics, and the statuses.

**Problem.** A problem ``p`` is an instance of a ``typing.NamedTuple`` subclass that carries four njit
functions as class attributes; the solvers reach them through the interface calls below
(:func:`dynamics._numba.boundary.interface_call`: numba overloads resolved at compile time from ``type(p)``,
so the callers stay cacheable, which passing functions as arguments would not).  A solver's entry point is
compiled with the problem's code, once per method and problem type (:mod:`dynamics.simulation.run`):

* ``rhs(p, t, z, dz)``: write dz = f(t, z);
* ``rebase(p, t, z, dz, mag)``: called after every accepted step (t: the time reached).  A problem that integrates in a moving chart
  (the robot's configuration, see :mod:`dynamics.configuration`) re-centres it here: it folds the chart
  coordinates of z into its base point and zeroes them, rewrites the chart part of ``dz = f(t, z)`` for the
  new chart, and stores in ``mag`` the magnitude of every state component (|q| for a chart coordinate) for
  the relative tolerance.  Plain ODEs do nothing;
* ``euler_config(p, z, h)``: symplectic Euler's position update from the (already updated) velocity part;
* ``emit(p, j, t, z)``: record output sample j at time t (z is in the chart of the current step);
* optionally ``touchdown(p)``: True once when the last accepted state touches something after touching nothing
  (``auto`` then switches to radau; a problem without it never touches).

State layout: z = [configuration part (nc), velocity part (nvel), quadratures].  Only the first ``ne``
components enter error norms and Newton convergence tests; components from ``ne`` on are quadratures (the
robot's work integral): f must not depend on them.

**Steppers.** A method is a NamedTuple of its workspace (stage arrays and a one-row record ``ctl`` of its
controller's scalars) whose class carries its njit functions, reached the same way:

* adaptive methods (:mod:`.adaptive` drives them): ``attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt,
  st, sw, rejected_last) -> (accepted, h_next)``: one attempted step of size h from (t, z) with f0 = f(t, z);
  when accepted it writes znew, fnew = f(t + h, znew) and errv (the local error vector);
  ``dense(m, p, t0, h, x, z0, z1, out, st)``: the state at t0 + x h of the last accepted step (z0 -> z1);
  ``order(m)``: the order used to pick the first step;
* fixed-step methods (:mod:`.fixed`): ``step(m, p, t, h, z, f0, st)`` advances z by h;
  ``fixed_dense(m, x, h, z0, f0, z1, f1, out)`` interpolates inside the step.

Each solver entry point (``solve_<method>`` in :mod:`dynamics.simulation.solvers`) builds its stepper, so a
compiled caller holds only the methods it can run.
"""

from typing import NamedTuple

import numpy as np

from numba.extending import overload

from ..._numba import GENERIC_OPTIONS
from ..._numba.boundary import _IMPL_OPTIONS, interface_call

OK, NONFINITE, BLOWUP, MAX_STEPS, STEP_TOO_SMALL, SWITCHED = 0, 1, 2, 3, 4, 5
#: SWITCHED is never a run's final status: ``auto`` resumes with its other method (:mod:`.auto`)
STATUS_NAMES = ("ok", "nonfinite", "blowup", "max_steps", "step_too_small", "switched")

RK45, RADAU = 0, 1  # what the auto switch logs in ``Switch.to``
SWITCH_STIFF, SWITCH_NONSTIFF, SWITCH_CONTACT = 0, 1, 2  # switch reasons
MAX_SWITCHES = 64


class Options(NamedTuple):
    """What a solver is asked to do (scalars, read-only)."""

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


#: statistics, one row written by the solvers (``np.zeros(1, STATS)``, then ``st = stats[0]`` in numba)
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


# ---------------------------------------------------------------------------------------------------
# the problem interface (compiled code only)
#: ``problem_rhs(p, t, z, dz)``: dz = f(t, z)
problem_rhs = interface_call("rhs", ("p", "t", "z", "dz"))
#: ``problem_rebase(p, t, z, dz, mag)``: re-centre the chart after an accepted step (t: the time reached, for
#: a problem that projects the state and re-evaluates dz there)
problem_rebase = interface_call("rebase", ("p", "t", "z", "dz", "mag"))
#: ``problem_euler_config(p, z, h)``: symplectic Euler's configuration update
problem_euler_config = interface_call("euler_config", ("p", "z", "h"))
#: ``problem_emit(p, j, t, z)``: record output sample j
problem_emit = interface_call("emit", ("p", "j", "t", "z"))


def problem_touchdown(p):
    """Whether the problem's last accepted state touches something after touching nothing (``auto`` switches to
    radau then): the problem class's own ``touchdown(p)`` when it has one (a robot with contact), else False.
    Compiled code only (chosen at compile time from ``type(p)``)."""
    raise NotImplementedError("problem_touchdown: compiled code only")


def _never(p):
    return False


@overload(problem_touchdown, jit_options=GENERIC_OPTIONS)
def _ov_problem_touchdown(p):
    fn = getattr(getattr(p, "instance_class", None), "touchdown", None)
    if fn is None:
        return _never
    return getattr(fn, "py_func", fn)

# ---------------------------------------------------------------------------------------------------
# the stepper interface (compiled code only)
#: ``stepper_attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)``: one attempted
#: adaptive step
stepper_attempt = interface_call("attempt", ("m", "p", "t", "h", "z", "f0", "znew", "fnew", "errv", "mag", "opt",
                                                "st", "sw", "rejected_last"))
#: ``stepper_dense(m, p, t0, h, x, z0, z1, out, st)``: dense output of the last accepted adaptive step
stepper_dense = interface_call("dense", ("m", "p", "t0", "h", "x", "z0", "z1", "out", "st"))
#: ``stepper_order(m)``: order for the starting-step heuristic
stepper_order = interface_call("order", ("m",))
#: ``stepper_step(m, p, t, h, z, f0, st)``: one fixed step
stepper_step = interface_call("step", ("m", "p", "t", "h", "z", "f0", "st"))
#: ``stepper_fixed_dense(m, x, h, z0, f0, z1, f1, out)``: interpolation inside a fixed step
stepper_fixed_dense = interface_call("fixed_dense", ("m", "x", "h", "z0", "f0", "z1", "f1", "out"))


def driver_rhs(p, t, z, dz):
    """``problem_rhs(p, t, z, dz)`` for the drivers' own evaluations (the first slope, Hairer's starting step):
    compiled code only.  An ``overload`` that is not inlined: numba keys an overload's implementation by its
    caller's flags, so the problem's rhs reached from here compiles once, under the steppers' flags; inlined into
    the entry point it would compile a second time under the entry point's."""
    raise NotImplementedError("driver_rhs: compiled code only")


def _driver_rhs(p, t, z, dz):
    problem_rhs(p, t, z, dz)


@overload(driver_rhs, jit_options=_IMPL_OPTIONS)
def _ov_driver_rhs(p, t, z, dz):
    return _driver_rhs
