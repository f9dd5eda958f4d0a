"""The compiled entry points: one cached kernel per method, so a call compiles (or loads) only the method it
runs (``auto``: rk45 and radau), and the stability probe of the fixed-step methods.

Each entry point takes a :class:`~.solvers.interface.Handle` of the problem (:mod:`.problem`): the address of
the problem's value and of its functions compiled for a pointer to it (:func:`handle`).  So the solvers are
compiled once, and cached, for every problem type (a constrained problem, an operational-space torque source),
and without the problem's code: the ABA and the torque source are optimised once, in the problem's own
functions, not again in every solver that calls them.  A new problem type compiles its four functions only.
The rule of borrowed values (:mod:`dynamics._numba`) holds: :func:`run` holds the problem, and the buffer of its
packed value, until the entry point returns.
"""

import logging
import time

from numba import typeof, types

from .._numba import kernel, native_address, pack
from . import solvers
from .solvers.interface import BY_REFERENCE, Handle

log = logging.getLogger("dynamics.simulation")


_ADDRESSES = {}  # (problem type, function name) -> its address (this process)


def handle(p, needs=("rhs", "rebase", "emit")):
    """The :class:`~.solvers.interface.Handle` of problem p, and the buffer holding p's value (keep both, and
    p, alive while the handle is used).  The problem's functions take the problem or a pointer to it
    (:func:`dynamics._numba.deref`): each is compiled, and cached, once per problem type for a pointer, and
    only those in ``needs`` (the others' addresses are 0: euler_config serves the Euler method alone)."""
    ty = typeof(p)
    addresses = []
    for name, args in BY_REFERENCE.items():
        key = (ty, name)
        if key not in _ADDRESSES and name in needs:
            _ADDRESSES[key] = native_address(getattr(type(p), name), types.none(types.CPointer(ty), *args))
        addresses.append(_ADDRESSES.get(key, 0))
    buf = pack(p)
    return Handle(buf.ctypes.data, *addresses), buf


# One entry point per method, compiled once for every problem type (they take a Handle).  Six small functions,
# not one generic one: a run compiles only its own method's solver (a generic entry would compile them all).
@kernel
def _euler(h, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_euler(h, z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _rk4(h, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_rk4(h, z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _rk45(h, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_rk45(h, z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _dop853(h, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_dop853(h, z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _radau(h, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_radau(h, z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _auto(h, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_auto(h, z, t0, t_end, out_t, opt, stats, sw)


ENTRY = {"euler": _euler, "rk4": _rk4, "rk45": _rk45, "dop853": _dop853, "radau": _radau, "auto": _auto}


#: seconds to compile a method's entry point and the problem's functions from an empty cache (2R arm, measured
#: on a loaded 2-core machine, process CPU time less the library's)
COMPILE_SECONDS = {"euler": 12, "rk4": 12, "rk45": 20, "dop853": 25, "radau": 30, "auto": 18}
#: the problem functions a method calls (euler_config serves the symplectic Euler method alone)
NEEDS = {"euler": ("rhs", "rebase", "emit", "euler_config")}


def _loaded(dispatcher, sig):
    """Whether ``dispatcher`` is compiled for ``sig`` (a tuple of argument types, or a Signature: numba's cache
    keys an overload by the form it was compiled with, a Signature for :func:`native_address`) in this process
    or in numba's on-disk cache (then loaded now)."""
    if tuple(getattr(sig, "args", sig)) in dispatcher.overloads:
        return True
    try:
        cres = dispatcher._cache.load_overload(sig, dispatcher.targetctx)  # numba's own cache lookup
    except Exception:  # numba internals moved: stay quiet rather than fail a simulation
        return True
    if cres is None:
        return False
    dispatcher.add_overload(cres)
    return True


def _announce(dispatcher, name, args, also=()):
    """Say once, before numba compiles ``dispatcher`` for these arguments (or a (dispatcher, argument types)
    pair of ``also``), that it is about to and for how long; kernels already compiled in this process or found
    in numba's on-disk cache say nothing."""
    if all(_loaded(d, types_) for d, types_ in ((dispatcher, tuple(map(dispatcher.typeof_pyval, args))), *also)):
        return
    log.warning("compiling the simulation kernels for %r (first run, about %d s; cached afterwards)", name,
                COMPILE_SECONDS.get(name, 20))


def run(method, p, z, t_end, opt, t0=0.0, watch=None):
    """Run ``method`` on problem p from (t0, z) to t_end (z is advanced in place).  ``watch(p)`` if given is a
    context manager held while the compiled loop runs (the progress bar).  Returns (stats record, the switch
    log's used rows, wall time of the run)."""
    entry = ENTRY[method]
    stats, sw = solvers.new_stats(), solvers.new_switch_log()
    needs = NEEDS.get(method, ("rhs", "rebase", "emit"))
    ty = typeof(p)
    problem_fns = [(getattr(type(p), n), types.none(types.CPointer(ty), *BY_REFERENCE[n])) for n in needs]
    _announce(entry, method, (Handle(0, 0, 0, 0, 0), z, float(t0), float(t_end), p.out_t, opt, stats, sw),
              problem_fns)
    h, buf = handle(p, needs)
    args = (h, z, float(t0), float(t_end), p.out_t, opt, stats, sw)
    tic = time.perf_counter()
    if watch is None:
        entry(*args)
    else:
        with watch(p):
            entry(*args)
    wall = time.perf_counter() - tic
    del buf  # held (with p) until the entry point returned
    st = stats[0]
    return st, sw[:st["switches"]], wall
