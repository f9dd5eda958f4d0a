"""The compiled entry points: one cached kernel per method, so a call compiles (or loads) only the method it
runs (``auto``: its rk45 phase, and its radau phase only once a run turns stiff).

Each entry point takes the problem itself (:mod:`.problem`, :mod:`.constrained_problem`): numba compiles the
method's solver together with the problem's functions (the ABA or the KKT solve, the torque source; reached
through :mod:`dynamics._numba.boundary`'s interface calls), once per method and problem type, and caches the
result on disk.  A call from Python is then numba's dispatcher and nothing else: no packing, no addresses, and
the GIL released for the whole loop (``nogil``), so runs on several threads overlap.
"""

import logging
import threading
import time

from .._numba import borrow, kernel
from . import solvers
from .solvers import auto, dop853, euler, radau, rk4, rk45, solve_adaptive, solve_fixed

log = logging.getLogger("dynamics.simulation")


# One entry point per method, compiled (and cached) once per problem type.  Seven small functions, not one generic
# one: a run compiles only its own method's stepper (a generic entry would compile them all).  Each calls its
# driver directly with its stepper (one inlined layer: numba's inliner copies a callee's IR per call site, and a
# wrapper around the driver made it copy the driver twice, ~0.4 s of each first compile).  The driver gets the
# problem borrowed (no reference counts on its arrays; p, the argument, holds them for the call).
@kernel
def _euler(p, z, t0, t_end, out_t, opt, stats, sw):
    return solve_fixed(borrow(p), euler.Euler(opt.nc), z, t0, t_end, out_t, opt, stats)


@kernel
def _rk4(p, z, t0, t_end, out_t, opt, stats, sw):
    return solve_fixed(borrow(p), rk4.make(z.shape[0]), z, t0, t_end, out_t, opt, stats)


@kernel
def _rk45(p, z, t0, t_end, out_t, opt, stats, sw):
    return solve_adaptive(borrow(p), rk45.make(z.shape[0]), z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _dop853(p, z, t0, t_end, out_t, opt, stats, sw):
    return solve_adaptive(borrow(p), dop853.make(z.shape[0]), z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _radau(p, z, t0, t_end, out_t, opt, stats, sw):
    return solve_adaptive(borrow(p), radau.make(z.shape[0]), z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _auto_rk45(p, z, t0, t_end, out_t, opt, stats, sw):
    """auto's non-stiff phase: rk45 until its stiffness test fires (status SWITCHED) or t_end."""
    return solve_adaptive(borrow(p), auto.make_rk45(z.shape[0]), z, t0, t_end, out_t, opt, stats, sw)


@kernel
def _auto_radau(p, z, t0, t_end, out_t, opt, stats, sw):
    """auto's stiff phase: radau until the problem has been non-stiff for a while (status SWITCHED) or t_end."""
    return solve_adaptive(borrow(p), auto.make_radau(z.shape[0]), z, t0, t_end, out_t, opt, stats, sw)


ENTRY = {"euler": _euler, "rk4": _rk4, "rk45": _rk45, "dop853": _dop853, "radau": _radau,
         "auto (rk45)": _auto_rk45, "auto (radau)": _auto_radau}


#: seconds to compile a method's entry point with a problem's functions from an empty cache (2R arm, the first
#: simulate's wall time; auto 22-26 s on the benchmarks page's machine, 2026-11-28; a loaded machine takes longer)
COMPILE_SECONDS = {"euler": 15, "rk4": 15, "rk45": 20, "dop853": 25, "radau": 25, "auto (rk45)": 25,
                   "auto (radau)": 25}
#: what contact adds to a first compilation (the narrow phase and the force law in the right-hand side, and for
#: radau the contact's force derivatives; the ball's first auto run, 2026-11-28: its rk45 phase ~103 CPU s, its
#: radau phase ~125 s, against ~25 s for a phase without contact)
CONTACT_COMPILE_SECONDS = 85
#: a first call that has not returned after this many seconds is compiling (numba's cache loads in less)
ANNOUNCE_AFTER = 1.5
_SEEN = set()  # the (method, problem kind) pairs run in this process: their entry points are compiled
_SEEN_LOCK = threading.Lock()


def _kind(method, p):
    """What selects a compiled entry point, in Python terms (cheaper than numba's typeof of the whole problem):
    the method, the problem's class, its torque kind, its chart (free joint or not) and whether it has contact."""
    return method, type(p), type(p.tag), type(p.chart), p.ws_source[0] is None, p.contact is None


class _announcing:
    """Around the first call of ``dispatcher`` for a kind of problem in this process: if it has neither
    returned nor gained a compiled signature after ``after`` seconds, numba is compiling: say so once, and for
    about how long (a timer thread; loading numba's on-disk cache is quicker and says nothing, and a long run
    after a quick load is not mistaken for a compilation).  Later calls of the same key pass through."""

    def __init__(self, dispatcher, key, name, after=ANNOUNCE_AFTER):
        self.dispatcher, self.key, self.name, self.after, self.timer = dispatcher, key, name, after, None

    def __enter__(self):
        with _SEEN_LOCK:
            first = self.key not in _SEEN
            _SEEN.add(self.key)
        if first:
            self.compiled = len(self.dispatcher.signatures)
            self.timer = threading.Timer(self.after, self._still_compiling)
            self.timer.daemon = True
            self.timer.start()
        return self

    def _still_compiling(self):
        if len(self.dispatcher.signatures) == self.compiled:
            contact = not self.key[-1]  # (the kind's last item: the problem has no contact)
            seconds = COMPILE_SECONDS.get(self.name, 20) + (CONTACT_COMPILE_SECONDS if contact else 0)
            # compile_seconds: the same estimate for a program (the service's worker tells its pool, which then
            # lets a request's deadline pass without killing the compilation)
            log.warning("compiling the simulation kernels for %r%s (first run, about %d s; cached afterwards)",
                        self.name, " with contact" if contact else "", seconds, extra={"compile_seconds": seconds})

    def __exit__(self, *exc):
        if self.timer is not None:
            self.timer.cancel()


def run(method, p, z, t_end, opt, t0=0.0, watch=None):
    """Run ``method`` on problem p from (t0, z) to t_end (z is advanced in place).  ``watch(p)`` if given is a
    context manager held while the compiled loop runs (the progress bar).  Returns (stats record, the switch
    log's used rows, wall time of the run)."""
    stats, sw = solvers.new_stats(), solvers.new_switch_log()
    args = (p, z, float(t0), float(t_end), p.out_t, opt, stats, sw)
    tic = time.perf_counter()
    if watch is None:
        _call(method, args)
    else:
        with watch(p):
            _call(method, args)
    wall = time.perf_counter() - tic
    st = stats[0]
    return st, sw[:st["switches"]], wall


def _call(method, args):
    """Run ``method``'s entry point (auto: its phases, :func:`.solvers.drive_auto`), announcing a compilation."""
    if method == "auto":
        solvers.drive_auto((_announced("auto (rk45)"), _announced("auto (radau)")), *args)
    else:
        _announced(method)(*args)


def _announced(name):
    """The entry point ``name`` as a function that announces its first compilation for a kind of problem."""
    entry = ENTRY[name]

    def call(p, *args):
        with _announcing(entry, _kind(name, p), name):
            return entry(p, *args)
    return call
