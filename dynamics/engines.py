"""Where many independent pieces of work run: this process's threads, local processes, or a Ray cluster.

    results = map_chunks(fn, shared, items, engine="threads" | "processes" | "ray", progress=None)

``fn(shared, chunk) -> list`` is applied to consecutive chunks of ``items``; ``shared`` (the model) is sent to
each worker once (Ray: one ``ray.put`` into the object store; processes: once per worker process).  Results come
back in the order of ``items``.

Chunking: a chunk should cost much more than handing it to a worker (~1 ms per Ray task, ~0.1 ms per process
task, ~20 us per thread task) so that overhead stays under :data:`MAX_OVERHEAD` of the work, yet there should be
several chunks per worker so that uneven pieces still balance.  :func:`chunk_size` picks it from a measured cost
of one item.

Progress: ``progress=None`` shows a tqdm bar when stderr is a terminal and nothing otherwise, ``True``/``False``
force it on/off, and a callable ``progress(done, total)`` is called after every chunk (for programs).

Processes: workers start by forkserver (spawn elsewhere), which imports the main script again in each worker
process; a script that calls us at its top level, outside ``if __name__ == "__main__":``, would then run again
in every worker and break the pool.  :func:`check_main_guard` finds that before any worker starts and says so.

Ray is optional (``pip install 'dynamics[ray]'``).  ``engine="ray"`` connects to ``ray_address`` (an existing
cluster, e.g. "ray://head:10001" or "auto"), or starts a local Ray on first use.
"""

import ast
import importlib
import math
import multiprocessing
import os
import sys
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

from .errors import InputError
from .parallel import num_threads

ENGINES = ("threads", "processes", "ray")
#: target share of the run time spent handing chunks to workers
MAX_OVERHEAD = 0.05
#: measured hand-off cost of one chunk per engine (seconds)
TASK_OVERHEAD = {"threads": 2e-5, "processes": 2e-4, "ray": 1e-3}
#: chunks per worker when the work allows it (uneven runs still balance)
CHUNKS_PER_WORKER = 4


def check_engine(engine):
    if engine not in ENGINES:
        raise InputError(f"engine: expected one of {list(ENGINES)}, got {engine!r}")


def ray_module():
    """The ray package, or an error that says how to install it."""
    try:
        return importlib.import_module("ray")  # optional: imported only when asked for
    except ImportError:
        raise InputError("engine='ray' needs Ray: pip install 'dynamics[ray]' (or pip install 'ray[default]')") \
            from None


def ray_init(address=None, num_cpus=None):
    """Connect to ``address`` (or start a local Ray, quietly) unless this process is connected already."""
    ray = ray_module()
    if not ray.is_initialized():
        kwargs = {"address": address} if address else {"num_cpus": num_cpus}
        ray.init(ignore_reinit_error=True, log_to_driver=False, include_dashboard=False, **kwargs)
    return ray


def workers(engine, ray_address=None):
    if engine == "ray":
        ray = ray_init(ray_address)
        return max(1, int(ray.cluster_resources().get("CPU", 1)))
    return num_threads()


def chunk_size(n_items, seconds_per_item, engine, n_workers):
    """Items per chunk: overhead below MAX_OVERHEAD of the work, yet CHUNKS_PER_WORKER chunks per worker."""
    by_overhead = math.ceil(TASK_OVERHEAD[engine] / (MAX_OVERHEAD * max(seconds_per_item, 1e-9)))  # at least
    by_balance = math.ceil(n_items / (CHUNKS_PER_WORKER * n_workers))  # at most, for balance; overhead wins
    return max(1, min(n_items, max(by_overhead, by_balance)))


class Progress:
    """A tqdm bar on a terminal, a callback, or nothing (see the module docstring)."""

    def __init__(self, progress, total, desc):
        self.callback = progress if callable(progress) else None
        show = progress is True or (progress is None and sys.stderr.isatty())
        self.bar = None
        if show and self.callback is None:
            tqdm = importlib.import_module("tqdm.auto").tqdm  # only when a bar is shown
            self.bar = tqdm(total=total, desc=desc, unit="run" if desc == "simulate" else "item", leave=False)
        self.done, self.total = 0, total

    def update(self, n):
        self.done += n
        if self.bar is not None:
            self.bar.update(n)
        if self.callback is not None:
            self.callback(self.done, self.total)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _chunks(items, size):
    return [(k, items[k:k + size]) for k in range(0, len(items), size)]


_process_shared = {}


def _process_init(shared):
    _process_shared["shared"] = shared


def _process_call(fn, chunk):
    return fn(_process_shared["shared"], chunk)


def _is_main_test(test):
    """``__name__ == "__main__"`` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = [test.left, test.comparators[0]]
    return (any(isinstance(x, ast.Name) and x.id == "__name__" for x in sides)
            and any(isinstance(x, ast.Constant) and x.value == "__main__" for x in sides))


def check_main_guard():
    """Raise InputError if the main script called us from its top level outside an ``if __name__ ==
    "__main__":`` block (module docstring).  Interactive sessions, ``python -c`` and notebooks pass: their main
    module is not imported again by the workers."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    frame = sys._getframe(1)
    while frame is not None and not (frame.f_code.co_name == "<module>" and frame.f_globals is vars(main)):
        frame = frame.f_back
    if frame is None or not path or not os.path.isfile(path):
        return
    try:
        with open(path, encoding="utf-8") as f:
            tree = ast.parse(f.read())
    except (OSError, SyntaxError, ValueError):
        return
    line = frame.f_lineno
    for node in tree.body:
        if isinstance(node, ast.If) and _is_main_test(node.test) and node.lineno <= line <= node.end_lineno:
            return
    raise InputError(f"engine='processes': {os.path.basename(path)} line {line} starts worker processes from the "
                     "script's top level; each worker imports the script again and would run it again. Put the "
                     "script's work under `if __name__ == \"__main__\":` (or use engine='threads')")


def _collect(futures_by_start, progress, total):
    """Wait for every future, reporting progress as chunks finish; results in the order of their starts.
    (as_completed registers one waiter per future once: a wait(FIRST_COMPLETED) per finished chunk registered one on
    every pending future each time, O(chunks^2) under the GIL: 1,000 one-run chunks cost the calling thread ~1 s of
    CPU, taken from the workers.)"""
    start_of = {f: s for s, f in futures_by_start.items()}
    out = {}
    for f in as_completed(start_of):
        start = start_of[f]
        out[start] = f.result()
        progress.update(len(out[start]))
    return [r for start in sorted(out) for r in out[start]]


def map_chunks(fn, shared, items, *, engine="threads", chunk=1, progress=None, desc="work", ray_address=None):
    """``[r for c in chunks(items) for r in fn(shared, c)]`` on the chosen engine (module docstring)."""
    check_engine(engine)
    items = list(items)
    bar = Progress(progress, len(items), desc)
    try:
        chunks = _chunks(items, max(1, int(chunk)))
        if engine == "threads":
            with ThreadPoolExecutor(max_workers=num_threads(), thread_name_prefix="dynamics-map") as pool:
                return _collect({k: pool.submit(fn, shared, c) for k, c in chunks}, bar, len(items))
        if engine == "processes":
            check_main_guard()
            context = multiprocessing.get_context("forkserver" if os.name == "posix" else "spawn")
            try:
                with ProcessPoolExecutor(max_workers=num_threads(), mp_context=context, initializer=_process_init,
                                         initargs=(shared,)) as pool:
                    return _collect({k: pool.submit(_process_call, fn, c) for k, c in chunks}, bar, len(items))
            except BrokenProcessPool as e:
                raise RuntimeError("engine='processes': a worker process died (killed, out of memory, or it failed "
                                   "to import the main script); its error is printed above") from e
        return _map_ray(fn, shared, chunks, bar, ray_address)
    finally:
        bar.close()


def _map_ray(fn, shared, chunks, bar, ray_address):
    ray = ray_init(ray_address)
    shared_ref = ray.put(shared)  # the model crosses to the object store once
    task = ray.remote(max_retries=3, retry_exceptions=False)(_ray_call)
    refs = {task.remote(fn, shared_ref, c): k for k, c in chunks}
    out, pending = {}, list(refs)
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        for ref in done:
            out[refs[ref]] = ray.get(ref)
            bar.update(len(out[refs[ref]]))
    return [r for k in sorted(out) for r in out[k]]


def _ray_call(fn, shared, chunk):
    return fn(shared, chunk)
