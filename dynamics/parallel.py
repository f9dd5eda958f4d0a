"""Batches over threads, and deadlines for long batches.

A batch of states is split into one chunk per core and the chunks run on a shared thread pool: the kernels
are ``nogil`` and keep no state between calls (each chunk owns its workspace), so concurrent calls from any
number of threads are safe.  Below :data:`MIN_PARALLEL_BATCH` states a batch runs on the calling thread
(a thread hand-off costs ~20 us).

Inside ``with deadline(t):`` (t on :func:`time.monotonic`'s clock) each thread works through its chunk in
pieces of about :data:`PIECE_SECONDS` and checks the clock between them; past ``t`` the call raises
:class:`~dynamics.errors.DeadlineExceeded`.  A server uses this to bound a request's time without chunking
batches itself.
"""

import contextlib
import contextvars
import math
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .checks import singular_joint_error
from .errors import DeadlineExceeded

MIN_PARALLEL_BATCH = 64
#: with a deadline, the work between two looks at the clock (seconds)
PIECE_SECONDS = 0.002

_deadline = contextvars.ContextVar("dynamics_deadline", default=None)
_threads = None
_pool = None
_pool_lock = threading.Lock()


def num_threads() -> int:
    """Threads a batch is spread over: $DYNAMICS_NUM_THREADS, else the cores this process may use."""
    global _threads
    if _threads is None:
        env = os.environ.get("DYNAMICS_NUM_THREADS")
        if env:
            _threads = max(1, int(env))
        else:
            try:
                _threads = max(1, len(os.sched_getaffinity(0)))
            except AttributeError:  # pragma: no cover - not Linux
                _threads = max(1, os.cpu_count() or 1)
    return _threads


def _executor():
    global _pool
    if _pool is None:
        with _pool_lock:
            if _pool is None:
                _pool = ThreadPoolExecutor(max_workers=num_threads(), thread_name_prefix="dynamics")
    return _pool


@contextlib.contextmanager
def deadline(t):
    """Batched calls inside this block raise DeadlineExceeded once ``time.monotonic()`` passes ``t``."""
    token = _deadline.set(None if t is None else float(t))
    try:
        yield
    finally:
        _deadline.reset(token)


def seconds_left():
    """Seconds until the deadline of the enclosing :func:`deadline` block (may be negative), inf outside one: what
    a long computation in the core (a simulation) is given to stop by."""
    t_end = _deadline.get()
    return math.inf if t_end is None else t_end - time.monotonic()


def check_deadline(done, total):
    """For a Python loop over a batch (:func:`dynamics.assemble`): raise DeadlineExceeded once the deadline of
    the enclosing :func:`deadline` block has passed, ``done`` of ``total`` states being done."""
    t_end = _deadline.get()
    if t_end is not None and time.monotonic() > t_end:
        raise DeadlineExceeded(f"the batch of {total} states ran past its deadline; {done} were done",
                               done=done, total=total)


def run(kernel, model, *args, out, singular=None):
    """Run the core's batch ``kernel(model.core, *args, out, threads, seconds)`` into ``out`` (B rows) on
    :func:`num_threads` threads, inside the deadline of the enclosing :func:`deadline` block: the core looks at
    the clock between states and stops past it (DeadlineExceeded here).  A state whose joint makes M singular
    (ABA, M^-1) is an InputError naming the joint, ``singular`` naming the computation."""
    B = out.shape[0]
    t_end = _deadline.get()
    seconds = math.inf if t_end is None else t_end - time.monotonic()
    done, expired, failed, body = kernel(model.core, *args, out, num_threads(), seconds)
    if expired:
        raise DeadlineExceeded(f"the batch of {B} states ran past its deadline; {done} were done", done=done,
                               total=B)
    if failed >= 0:
        raise singular_joint_error(model, body, singular)
    return out


def _rows(batched, B, lo, hi):
    return [x[lo:hi] if x.shape[0] == B else x for x in batched]


def _run_piecewise(kernel, tree, batched, shared, out, lo, hi, t_end):
    """Run rows lo:hi in pieces sized to ~PIECE_SECONDS, checking the deadline between pieces."""
    B = out.shape[0]
    step, start = 8, lo
    while start < hi:
        if time.monotonic() > t_end:
            raise DeadlineExceeded(f"the batch of {B} states ran past its deadline; {start - lo} of the "
                                   f"{hi - lo} states of this chunk were done", done=start - lo, total=B)
        stop = min(hi, start + step)
        t0 = time.perf_counter()
        kernel(tree, *_rows(batched, B, start, stop), *shared, out[start:stop])
        took = max(time.perf_counter() - t0, 1e-7)
        step = max(1, min(4 * step, int(step * PIECE_SECONDS / took)))
        start = stop


def run_chunks(kernel, tree, batched, shared, out):
    """Run ``kernel(tree, *batched_rows, *shared, out_rows)`` over chunks of the leading axis of ``out``.

    Every array of ``batched`` has B rows (sliced with ``out``) or one row (shared by every state).
    """
    B = out.shape[0]
    t_end = _deadline.get()
    nt = num_threads() if B >= MIN_PARALLEL_BATCH else 1
    if nt == 1:
        if t_end is None:
            kernel(tree, *batched, *shared, out)
        else:
            _run_piecewise(kernel, tree, batched, shared, out, 0, B, t_end)
        return out
    bounds = np.linspace(0, B, nt + 1).astype(int)
    futures = []
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        if hi <= lo:
            continue
        if t_end is None:
            futures.append(_executor().submit(kernel, tree, *_rows(batched, B, lo, hi), *shared, out[lo:hi]))
        else:
            futures.append(_executor().submit(_run_piecewise, kernel, tree, batched, shared, out, lo, hi, t_end))
    for fut in futures:
        fut.result()
    return out
