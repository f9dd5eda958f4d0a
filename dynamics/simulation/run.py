"""The compiled entry points: one cached kernel per method, so a call compiles (or loads) only the method it
runs (``auto``: rk45 and radau), and the stability probe of the fixed-step methods.

Each entry point takes the problem (:mod:`.problem`) and runs it through a borrowed copy
(:func:`dynamics._numba.borrowed`: no reference counting per right-hand side).  The rule of borrowed values
holds without a ``keep_alive``: the problem is an argument built in Python, and the Python caller (:func:`run`)
holds it, so every array stays alive until the entry point returns.  Any problem type with the solver interface can be passed (a constrained variant
included): numba compiles, and caches, one specialisation per type.
"""

import logging
import time

import numpy as np

from .._numba import borrowed, kernel
from . import solvers

log = logging.getLogger("dynamics.simulation")


@kernel
def _euler(p, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_euler(borrowed(p), z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _rk4(p, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_rk4(borrowed(p), z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _rk45(p, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_rk45(borrowed(p), z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _dop853(p, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_dop853(borrowed(p), z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _radau(p, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_radau(borrowed(p), z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _auto(p, z, t0, t_end, out_t, opt, stats, sw):
    return solvers.solve_auto(borrowed(p), z, t0, t_end, out_t, opt, stats, sw)


ENTRY = {"euler": _euler, "rk4": _rk4, "rk45": _rk45, "dop853": _dop853, "radau": _radau, "auto": _auto}


#: seconds to compile each entry point from an empty cache (2R arm, measured on a loaded 2-core machine)
COMPILE_SECONDS = {"euler": 10, "rk4": 10, "rk45": 15, "dop853": 20, "radau": 20, "auto": 20}


def _announce(dispatcher, name, args):
    """Say once, before numba compiles ``dispatcher`` for these arguments, that it is about to and for how
    long; a kernel already compiled in this process or found in numba's on-disk cache says nothing."""
    if dispatcher.overloads:
        return
    try:
        sig = tuple(dispatcher.typeof_pyval(a) for a in args)
        cres = dispatcher._cache.load_overload(sig, dispatcher.targetctx)  # numba's own cache lookup
    except Exception:  # numba internals moved: stay quiet rather than fail a simulation
        return
    if cres is not None:
        dispatcher.add_overload(cres)
        return
    log.warning("compiling the simulation kernels for %r (first run, about %d s; cached afterwards)", name,
                COMPILE_SECONDS.get(name, 20))


def run(method, p, z, t_end, opt, t0=0.0, watch=None):
    """Run ``method`` on problem p from (t0, z) to t_end (z is advanced in place).  ``watch(p)`` if given is a
    context manager held while the compiled loop runs (the progress bar).  Returns (stats record, the switch
    log's used rows, wall time of the run)."""
    entry = ENTRY[method]
    stats, sw = solvers.new_stats(), solvers.new_switch_log()
    args = (p, z, float(t0), float(t_end), p.out_t, opt, stats, sw)
    _announce(entry, method, args)
    tic = time.perf_counter()
    if watch is None:
        entry(*args)
    else:
        with watch(p):
            entry(*args)
    wall = time.perf_counter() - tic
    st = stats[0]
    return st, sw[:st["switches"]], wall

