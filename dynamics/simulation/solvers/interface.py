"""What the solvers and the problem say to each other: the problem interface, the stepper interface, the
named options and statistics, and the statuses.

**Problem.** A problem ``p`` is an instance of a ``typing.NamedTuple`` subclass that carries four njit
functions as class attributes; the solvers reach them through the static calls below
(:func:`_static_call`), resolved at compile time from ``type(p)`` (so the callers stay cacheable, which
passing functions as arguments would not).  Or ``p`` is a :class:`Handle`: the address of a problem value and
of its functions compiled for a pointer to it (:func:`dynamics.simulation.run.handle`); the same calls then go
through those addresses, so a solver compiled for a Handle serves every problem type and holds none of the
problem's code (the library's simulations run this way; the plain form serves the solvers' own tests):

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
from numba.core import types
from numba.extending import intrinsic

from ..._numba import call_address

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


class Handle(NamedTuple):
    """A problem behind an opaque boundary: the address of the problem value (:func:`dynamics._numba.pack`) and
    of its four functions compiled for a pointer to it (:data:`BY_REFERENCE`).  The solvers compiled for a
    Handle call the problem through these addresses: they compile once, whatever the problem type, and
    without the problem's code (the ABA and the torque source are optimised in the problem's functions only)."""

    problem: int
    rhs: int
    rebase: int
    euler_config: int
    emit: int


_VEC = types.float64[::1]
#: the arguments after the problem of the problem functions called through a :class:`Handle` (the callers'
#: arguments are cast to these)
BY_REFERENCE = {"rhs": (types.float64, _VEC, _VEC), "rebase": (types.float64, _VEC, _VEC, _VEC),
                "euler_config": (_VEC, types.float64), "emit": (types.int64, types.float64, _VEC)}
_FIELD = {name: Handle._fields.index(name) for name in BY_REFERENCE}


def _is_handle(ty):
    return getattr(ty, "instance_class", None) is Handle


def _handle_typer(name, argtys):
    args = BY_REFERENCE[name]
    callee = types.none(types.voidptr, *args)

    def codegen(context, builder, sig, llargs):
        h = llargs[0]
        ptr = builder.inttoptr(builder.extract_value(h, 0), context.get_value_type(types.voidptr))
        vals = [ptr] + [context.cast(builder, v, a, b) for v, a, b in zip(llargs[1:], argtys[1:], args)]
        call_address(context, builder, builder.extract_value(h, _FIELD[name]), callee, vals)
        return context.get_dummy_value()
    return types.none(*argtys), codegen


def _call_typer(name, typingctx, argtys):
    if _is_handle(argtys[0]):
        return _handle_typer(name, argtys)
    fnty = types.Dispatcher(_bound(argtys[0], name))
    sig = typingctx.resolve_function_type(fnty, argtys, {})
    if sig is None:
        return None

    def codegen(context, builder, _sig, llargs):
        vals = [context.cast(builder, v, a, b) for v, a, b in zip(llargs, argtys, sig.args)]
        return context.get_function(fnty, sig)(builder, vals)
    return sig.return_type(*argtys), codegen


def _static_call(name, nargs):
    """An intrinsic ``call(obj, a0, .., a<nargs-1>)`` that calls ``type(obj).<name>(obj, a0, ...)``: the njit
    function is resolved at compile time from the NamedTuple class of ``obj`` and called directly, as if the
    caller had named it.

    Why not an ``@overload(inline="always")`` stub: numba compiles an inlined overload's implementation in
    full (LLVM included) only to learn its return type, then inlines its IR and compiles it again in the
    caller, and every compiled layer re-optimises all the code it links in (the ABA, the torque source): the
    stubs cost more compile time than the solvers.  Here the bound function is compiled once, as itself, and
    linked into the caller (numba's own lowering of a call to a dispatcher).  numba's intrinsics take a fixed
    number of arguments, hence the generated signature."""
    params = ", ".join(f"a{i}" for i in range(nargs))
    ns = {}
    exec(f"def {name}(typingctx, obj, {params}):\n    return typer(typingctx, (obj, {params}))",
         {"typer": lambda typingctx, argtys: _call_typer(name, typingctx, argtys)}, ns)
    return intrinsic(ns[name])


# ---------------------------------------------------------------------------------------------------
# the problem interface (compiled code only)
#: ``problem_rhs(p, t, z, dz)``: dz = f(t, z)
problem_rhs = _static_call("rhs", 3)
#: ``problem_rebase(p, t, z, dz, mag)``: re-centre the chart after an accepted step (t: the time reached, for
#: a problem that projects the state and re-evaluates dz there)
problem_rebase = _static_call("rebase", 4)
#: ``problem_euler_config(p, z, h)``: symplectic Euler's configuration update
problem_euler_config = _static_call("euler_config", 2)
#: ``problem_emit(p, j, t, z)``: record output sample j
problem_emit = _static_call("emit", 3)

# ---------------------------------------------------------------------------------------------------
# the stepper interface (compiled code only)
#: ``stepper_attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)``: one attempted
#: adaptive step
stepper_attempt = _static_call("attempt", 13)
#: ``stepper_dense(m, p, t0, h, x, z0, z1, out, st)``: dense output of the last accepted adaptive step
stepper_dense = _static_call("dense", 8)
#: ``stepper_order(m)``: order for the starting-step heuristic
stepper_order = _static_call("order", 0)
#: ``stepper_step(m, p, t, h, z, f0, st)``: one fixed step
stepper_step = _static_call("step", 6)
#: ``stepper_fixed_dense(m, x, h, z0, f0, z1, f1, out)``: interpolation inside a fixed step
stepper_fixed_dense = _static_call("fixed_dense", 7)
