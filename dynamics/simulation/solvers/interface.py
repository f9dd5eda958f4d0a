"""What the solvers and the problem say to each other: the problem interface, the stepper interface, the
named options and statistics, and the statuses.

**Problem.** A problem ``p`` is an instance of a ``typing.NamedTuple`` subclass that carries four njit
functions as class attributes; the solvers reach them through the overloaded stubs below, resolved at
compile time from ``type(p)`` (static calls, so the callers stay cacheable, which passing functions as
arguments would not):

* ``rhs(p, t, z, dz)``: write dz = f(t, z);
* ``rebase(p, t, z, dz, mag)``: called after every accepted step (t: the time reached).  A problem that integrates in a moving chart
  (the robot's configuration, see :mod:`dynamics.configuration`) re-centres it here: it folds the chart
  coordinates of z into its base point and zeroes them, rewrites the chart part of ``dz = f(t, z)`` for the
  new chart, and stores in ``mag`` the magnitude of every state component (|q| for a chart coordinate) for
  the relative tolerance.  Plain ODEs do nothing;
* ``euler_config(p, z, h)``: symplectic Euler's position update from the (already updated) velocity part;
* ``emit(p, j, t, z)``: record output sample j at time t (z is in the chart of the current step).

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

# The stubs are inlined into their callers (numba IR inlining): each is one call to the bound function, and a
# separate compiled layer per stub would copy the problem tuple (tens of arrays) once more per call site.
INLINE = "always"

OK, NONFINITE, BLOWUP, MAX_STEPS, STEP_TOO_SMALL = 0, 1, 2, 3, 4
STATUS_NAMES = ("ok", "nonfinite", "blowup", "max_steps", "step_too_small")

RK45, RADAU = 0, 1  # what the auto switch logs in ``Switch.to``
SWITCH_STIFF, SWITCH_NONSTIFF = 0, 1  # switch reasons
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


def _bound(obj, name):
    fn = getattr(getattr(obj, "instance_class", None), name, None)
    if fn is None:
        raise TypeError(f"{obj} has no njit attribute {name!r} (problem or stepper NamedTuple class)")
    return fn


# ---------------------------------------------------------------------------------------------------
# the problem interface
def problem_rhs(p, t, z, dz):
    """dz = f(t, z) (compiled code only)."""
    raise NotImplementedError


def problem_rebase(p, t, z, dz, mag):
    """Re-centre the chart after an accepted step (compiled code only)."""
    raise NotImplementedError


def problem_euler_config(p, z, h):
    """Symplectic Euler's configuration update (compiled code only)."""
    raise NotImplementedError


def problem_emit(p, j, t, z):
    """Record output sample j (compiled code only)."""
    raise NotImplementedError


@overload(problem_rhs, jit_options=GENERIC_OPTIONS, inline=INLINE)
def _ov_rhs(p, t, z, dz):
    fn = _bound(p, "rhs")
    return lambda p, t, z, dz: fn(p, t, z, dz)


@overload(problem_rebase, jit_options=GENERIC_OPTIONS, inline=INLINE)
def _ov_rebase(p, t, z, dz, mag):
    fn = _bound(p, "rebase")
    return lambda p, t, z, dz, mag: fn(p, t, z, dz, mag)


@overload(problem_euler_config, jit_options=GENERIC_OPTIONS, inline=INLINE)
def _ov_euler_config(p, z, h):
    fn = _bound(p, "euler_config")
    return lambda p, z, h: fn(p, z, h)


@overload(problem_emit, jit_options=GENERIC_OPTIONS, inline=INLINE)
def _ov_emit(p, j, t, z):
    fn = _bound(p, "emit")
    return lambda p, j, t, z: fn(p, j, t, z)


# ---------------------------------------------------------------------------------------------------
# the stepper interface
def stepper_attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    """One attempted adaptive step (compiled code only)."""
    raise NotImplementedError


def stepper_dense(m, p, t0, h, x, z0, z1, out, st):
    """Dense output of the last accepted adaptive step (compiled code only)."""
    raise NotImplementedError


def stepper_order(m):
    """Order for the starting-step heuristic (compiled code only)."""
    raise NotImplementedError


def stepper_step(m, p, t, h, z, f0, st):
    """One fixed step (compiled code only)."""
    raise NotImplementedError


def stepper_fixed_dense(m, x, h, z0, f0, z1, f1, out):
    """Interpolation inside a fixed step (compiled code only)."""
    raise NotImplementedError


@overload(stepper_attempt, jit_options=GENERIC_OPTIONS, inline=INLINE)
def _ov_attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    fn = _bound(m, "attempt")
    return (lambda m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last:
            fn(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last))


@overload(stepper_dense, jit_options=GENERIC_OPTIONS, inline=INLINE)
def _ov_dense(m, p, t0, h, x, z0, z1, out, st):
    fn = _bound(m, "dense")
    return lambda m, p, t0, h, x, z0, z1, out, st: fn(m, p, t0, h, x, z0, z1, out, st)


@overload(stepper_order, jit_options=GENERIC_OPTIONS, inline=INLINE)
def _ov_order(m):
    fn = _bound(m, "order")
    return lambda m: fn(m)


@overload(stepper_step, jit_options=GENERIC_OPTIONS, inline=INLINE)
def _ov_step(m, p, t, h, z, f0, st):
    fn = _bound(m, "step")
    return lambda m, p, t, h, z, f0, st: fn(m, p, t, h, z, f0, st)


@overload(stepper_fixed_dense, jit_options=GENERIC_OPTIONS, inline=INLINE)
def _ov_fixed_dense(m, x, h, z0, f0, z1, f1, out):
    fn = _bound(m, "fixed_dense")
    return lambda m, x, h, z0, f0, z1, f1, out: fn(m, x, h, z0, f0, z1, f1, out)
