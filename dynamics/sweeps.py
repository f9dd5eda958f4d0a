"""Many simulations, or one huge batch, spread over threads, processes or a Ray cluster.

``simulate_many`` runs ``simulate`` once per initial state; every run's numbers are bit-identical to calling
:func:`dynamics.simulate` on it alone (it is the same call), and a run that fails (blow-up, step budget, bad
torque) is reported in its own report without sinking the others.

``map_batches(fn, model, *arrays)`` splits one batched call (``inverse_dynamics``, ``mass_matrix``, any
function of (model, batch, ...)) into chunks for an engine and stacks the answers.  One function for every
batched entry point, rather than an ``engine=`` keyword on each: the single-call fast paths stay untouched,
and it works for any function with that shape, the user's own included.
"""

import math
import time
import warnings
from typing import NamedTuple

import numpy as np

from . import engines
from .checks import check_model, real_number
from .contact.outputs import stack as stack_contacts
from .errors import InputError
from .simulation import simulate


class Trajectories(NamedTuple):
    """Runs sampled on a shared time grid: ``t`` (T,), ``q`` (B, T, nq), ``v`` (B, T, nv), ``tau`` (B, T, nv),
    ``reports`` (B dicts as from simulate, plus "run").  A run that stopped early is NaN after its last good
    sample; ``counts`` (B,) says how many samples each run has.  ``lam`` (B, T, m): the constraint multipliers
    of a constrained model when ``outputs`` asked for "lambda", else None.  ``sensitivities`` (B, T, 2 nv, ncol)
    when ``sensitivities`` asked for them (:func:`dynamics.simulate`), else None.  ``contacts``: the runs'
    active contacts per sample, stacked (:mod:`dynamics.contact.outputs`), when the Contact's outputs ask for
    "contacts", else None."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    tau: np.ndarray
    reports: list
    counts: np.ndarray
    lam: object = None
    sensitivities: object = None
    contacts: object = None

    @property
    def ok(self):
        """(B,) bool: the runs whose status is "ok"."""
        return np.array([r.get("status") == "ok" for r in self.reports])


class _Failed(NamedTuple):
    """A run that raised: its report says why."""

    report: dict


def _rows(name, x, n, B):
    X = np.asarray(x, dtype=float) if x is not None else np.zeros(n)
    if X.ndim == 1:
        X = np.broadcast_to(X, (B, n))
    if X.shape != (B, n):
        raise InputError(f"{name}: expected shape ({n},) or ({B}, {n}), got {X.shape}")
    return X


def _torques(torque, B):
    if isinstance(torque, (list, tuple)):
        if len(torque) != B:
            raise InputError(f"torque: a list of per-run torques must have one per run ({B}), got {len(torque)}")
        return list(torque)
    return [torque] * B


def _run_one(model, item):
    """One simulate call; any refusal or failure becomes that run's report."""
    k, q0, v0, torque, options = item
    options.setdefault("progress", False)  # the sweep has its own bar (runs)
    try:
        traj = simulate(model, q0, v0, options.pop("duration"), torque=torque, **options)
        return traj._replace(report=dict(traj.report, run=k))
    except (ValueError, ArithmeticError) as e:
        return _Failed({"run": k, "status": f"failed: {e}", "warnings": [str(e)]})


def _run_chunk(model, chunk):
    out = []
    for item in chunk:
        result = _run_one(model, (item[0], item[1], item[2], item[3], dict(item[4])))
        out.append(result)
    return out


def _stack(model, results, B):
    grids = [r.t for r in results if not isinstance(r, _Failed)]
    T = max((len(t) for t in grids), default=0)
    t = next((g for g in grids if len(g) == T), np.zeros(0))
    q, v, tau = (np.full((B, T, n), np.nan) for n in (model.nq, model.nv, model.nv))
    m = next((r.lam.shape[1] for r in results if not isinstance(r, _Failed) and r.lam is not None), None)
    lam = None if m is None else np.full((B, T, m), np.nan)
    shape = next((r.sensitivities.shape[1:] for r in results if not isinstance(r, _Failed)
                  and r.sensitivities is not None), None)
    sens = None if shape is None else np.full((B, T, *shape), np.nan)
    counts, reports = np.zeros(B, np.int64), []
    for k, r in enumerate(results):
        if isinstance(r, _Failed):
            reports.append(r.report)
            continue
        n = len(r.t)
        counts[k] = n
        for dst, src in ((q, r.q), (v, r.v), (tau, r.tau), (lam, r.lam), (sens, r.sensitivities)):
            if src is not None and src.shape[0] == n:
                dst[k, :n] = src
        reports.append(r.report)
    contacts = stack_contacts([None if isinstance(r, _Failed) else r.contacts for r in results], T)
    return Trajectories(t, q, v, tau, reports, counts, lam, sens, contacts)


def _runs_per_chunk(n_runs, seconds_per_run, engine, n_workers):
    """Runs per chunk: as few as the engine's hand-off cost allows (under engines.MAX_OVERHEAD of the work), and
    at most engines.CHUNKS_PER_WORKER chunks' worth per worker.  Unlike a batch's equal items, runs differ in length
    (the steps a run needs: 3-20 ms for benchmarks.scale's one-second Panda runs), and the workers' last chunks end
    unevenly; small chunks even them out (that benchmark's 1,000 runs, scheduled on 2 threads from their measured
    times: 0.990 of the ideal with 4 chunks per worker, 0.998 with a run per chunk; fewer runs gain more)."""
    by_overhead = math.ceil(engines.TASK_OVERHEAD[engine] / (engines.MAX_OVERHEAD * max(seconds_per_run, 1e-9)))
    by_balance = math.ceil(n_runs / (engines.CHUNKS_PER_WORKER * n_workers))
    return max(1, min(n_runs, by_overhead, by_balance))


def simulate_many(model, q0, v0, duration, *, torque=None, engine="threads", progress=None, ray_address=None,
                  **simulate_options):
    """Simulate B runs from q0 (B, nq) and v0 (B, nv) (either may be one row, shared).

    torque: one torque source for every run, or a list of B (a PD with its own target and gains per run, a
    Table per run, ...).  engine: "threads" (default, all local cores), "processes" or "ray" (``ray_address``
    of a cluster, or a local Ray started on demand).  progress: None (a bar on a terminal), True, False, or
    a callable ``progress(done, total)``.  Every other keyword goes to :func:`dynamics.simulate`.
    """
    check_model(model)
    engines.check_engine(engine)
    duration = real_number("duration", duration, lo=0.0)
    B = max(np.shape(q0)[0] if np.ndim(q0) == 2 else 1, np.shape(v0)[0] if np.ndim(v0) == 2 else 1)
    Q, V = _rows("q0", q0, model.nq, B), _rows("v0", v0, model.nv, B)
    options = dict(simulate_options, duration=duration)
    items = [(k, Q[k].copy(), V[k].copy(), tau, options) for k, tau in enumerate(_torques(torque, B))]
    t0 = time.perf_counter()
    first = _run_chunk(model, items[:1])  # measures one run for the chunk size
    per_run = time.perf_counter() - t0
    size = _runs_per_chunk(B - 1, per_run, engine, engines.workers(engine, ray_address)) if B > 1 else 1
    rest = engines.map_chunks(_run_chunk, model, items[1:], engine=engine, chunk=size, progress=progress,
                              desc="simulate", ray_address=ray_address) if B > 1 else []
    return _stack(model, first + rest, B)


def _batch_chunk(shared, ranges):
    fn, model, arrays, kwargs = shared
    return [fn(model, *[a[lo:hi] for a in arrays], **kwargs) for lo, hi in ranges]


def map_batches(fn, model, *arrays, engine="threads", chunk=None, progress=None, ray_address=None, **kwargs):
    """``fn(model, *arrays, **kwargs)`` on a batch (every array (B, ...)), computed chunk by chunk on an engine
    and stacked: for batches too large for one call or one machine (``fn``: inverse_dynamics, mass_matrix, ...).
    The arrays travel to each worker once; ``progress`` counts chunks.

    ``engine="processes"`` runs on threads, with a ``UserWarning`` saying so: the batched kernels release the
    GIL, so threads already use every core, while local processes pickled every chunk both ways (measured at
    0.14 efficiency on 2 M Talos states, issue 24).  For more than one machine, use ``engine="ray"``."""
    check_model(model)
    engines.check_engine(engine)
    if engine == "processes":
        warnings.warn("map_batches: engine='processes' runs on threads (the batched kernels release the GIL, and "
                      "processes would copy every chunk both ways); use engine='ray' for several machines",
                      UserWarning, stacklevel=2)
        engine = "threads"
    arrays = [np.ascontiguousarray(a) for a in arrays]
    B = arrays[0].shape[0] if arrays and arrays[0].ndim >= 1 else 0
    if not arrays or any(a.ndim < 1 or a.shape[0] != B for a in arrays):
        raise InputError(f"arrays: expected batches with the same first dimension, got {[a.shape for a in arrays]}")
    if chunk is None:
        t0 = time.perf_counter()
        fn(model, *[a[:256] for a in arrays], **kwargs)  # measures a small batch
        per_item = (time.perf_counter() - t0) / max(1, min(B, 256))
        chunk = max(engines.chunk_size(B, per_item, engine, engines.workers(engine, ray_address)), 1024)
    ranges = [(lo, min(B, lo + int(chunk))) for lo in range(0, B, int(chunk))]
    parts = engines.map_chunks(_batch_chunk, (fn, model, arrays, kwargs), ranges, engine=engine, chunk=1,
                               progress=progress, desc="batch", ray_address=ray_address)
    return np.concatenate(parts) if parts else fn(model, *arrays, **kwargs)
