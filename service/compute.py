"""Where the service calls the library: off the event loop, within a wall-time budget.

Two kinds of work, two mechanisms:

* Dynamics calls (inverse/forward dynamics, mass matrix, ...) have a cost known in advance (states x bodies),
  so they run in a small thread pool, and a batch is cut into chunks of bounded work with the deadline
  checked between chunks: a request past its budget stops within one chunk (a few milliseconds) and frees
  its thread. Threads keep the single-state path cheap (no pickling, no process hop).
* A simulation is one opaque library call whose cost the caller controls (duration, tolerances, a stiff
  system), so it runs in a worker process (:mod:`service.simpool`) that is killed when the budget runs out:
  the only way to really stop a computation that never checks a clock.
"""

from __future__ import annotations

import asyncio
import functools
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Callable, Optional

import numpy as np

from .errors import ApiError, bad_input, field_of
from .settings import Settings
from .store import ModelCache, RobotRecord, RobotStore

# Requests with bodies up to this size may run on the event loop (see service.app._dynamics_route).
INLINE_BYTES = 2048
# Work of one chunk, in body-states: about 1-5 ms of RNEA/ABA; the budget is checked between chunks.
CHUNK_WORK = 40_000


class BudgetExceeded(ApiError):
    def __init__(self, what: str, budget: float, hint: str):
        super().__init__(504, f"time budget: {what} was stopped after {budget:g} s (DYNAMICS_TIME_BUDGET or "
                              f"X-Time-Budget); {hint}",
                         code="time_budget_exceeded", field=None)


@dataclass(frozen=True)
class Operation:
    """One dynamics endpoint: the library function, its state arguments, its keyword arguments, its answer."""
    name: str                  # for messages: "inverse dynamics"
    func: Callable[..., np.ndarray]
    states: tuple[str, ...]    # positional state arguments, batched along axis 0
    keywords: tuple[str, ...]  # optional keyword arguments (gravity, f_ext)
    answer: str                # key of the answer: "tau", "a", "mass_matrix"
    cost: Callable[[Any], int]  # work per state, in body-states, for chunking
    # Where v and a come from, to tell which terms vanish: "state" (the request's array), "zero" (held at zero:
    # gravity torques, bias forces) or "computed" (ABA's answer is a). None: the operation has none of the
    # terms (the mass matrix), so nothing is reported skipped.
    terms: Optional[dict[str, str]] = None

    def skipped(self, args: dict[str, Any], model_gravity: np.ndarray) -> tuple[str, ...]:
        """Terms this request does not compute, for any state of its batch."""
        if self.terms is None:
            return ()
        present = [_nonzero(args[x]) if self.terms[x] == "state" else self.terms[x] == "computed" for x in "va"]
        g = args.get("gravity")
        return terms_skipped(present[0], present[1], _nonzero(model_gravity if g is None else g))


def load_model(record: RobotRecord):
    import dynamics

    # Always bytes: the library reads a str that does not start with '<' as a file path, and no path named
    # by a caller may ever be opened.
    return dynamics.load_urdf(record.urdf.encode("utf-8"), floating_base=record.floating_base)


# -- scenes: locked joints select a reduced model; every answer says what its model left out ---------------------
def locked_key(locked: Optional[dict[str, Any]]) -> tuple:
    """A request's ``locked`` -> the hashable, canonical part of a model cache key.

    Sorted by joint name, every value a tuple of floats, so that {"a": 1, "b": [2]} and {"b": 2.0, "a": 1.0}
    share one reduced model. ``+ 0.0`` turns -0.0 into 0.0 (the same pose).
    """
    if not locked:
        return ()
    return tuple(sorted((name, tuple(float(x) + 0.0 for x in (v if isinstance(v, (list, tuple)) else (v,))))
                        for name, v in locked.items()))


def reduce_model(model, key: tuple):
    """``dynamics.lock_joints`` for a :func:`locked_key`; its InputError names the joint ("locked: no movable
    joint named 'x'; joints are [...]", "locked['j']: expected 1 finite number, got [1.0, 2.0]")."""
    import dynamics

    return dynamics.lock_joints(model, {name: (v[0] if len(v) == 1 else list(v)) for name, v in key})


@dataclass(frozen=True)
class Loaded:
    """What the model cache holds: a model, and the part of every answer's scene that depends only on it."""
    model: Any
    scene: dict[str, Any]  # locked, pruned, merged_fixed_joints, nq, nv

    @classmethod
    def of(cls, model) -> "Loaded":
        info = model.summary()
        return cls(model, {"locked": info.get("locked_joints", {}), "pruned": list(info.get("links_pruned", [])),
                           "merged_fixed_joints": len(info.get("fixed_joints_merged", ())),
                           "nq": int(model.nq), "nv": int(model.nv)})

    def answer_scene(self, skipped: tuple[str, ...]) -> dict[str, Any]:
        s = self.scene
        return {"locked": s["locked"], "pruned": s["pruned"], "merged_fixed_joints": s["merged_fixed_joints"],
                "skipped": list(skipped), "nq": s["nq"], "nv": s["nv"]}


@functools.lru_cache(maxsize=None)
def terms_skipped(with_v: bool, with_a: bool, with_gravity: bool) -> tuple[str, ...]:
    """The library's names of the terms it leaves out (``dynamics.rnea.skipped_terms``), asked once per case:
    its np.any calls cost ~12 us, a third of a whole single-state request answered on the event loop."""
    from dynamics.rnea import skipped_terms

    return tuple(skipped_terms(v=float(with_v), a=float(with_a), gravity=(float(with_gravity), 0.0, 0.0)))


def simulation_scene(entry: Loaded, gravity: Optional[np.ndarray]) -> dict[str, Any]:
    """The scene of a simulation: velocities and accelerations evolve, so only gravity can be left out."""
    g = entry.model.gravity if gravity is None else gravity
    return entry.answer_scene(terms_skipped(True, True, _nonzero(g)))


def _nonzero(x: Any) -> bool:
    return bool(x.any()) if isinstance(x, np.ndarray) else bool(np.any(x))


class Compute:
    """The model cache, the thread pool and the deadline logic, shared by all requests of one process."""

    def __init__(self, settings: Settings, store: RobotStore):
        self.settings = settings
        self.store = store
        self.cache = ModelCache(settings.cache_size)
        self.executor = ThreadPoolExecutor(max_workers=settings.compute_threads, thread_name_prefix="dynamics")
        self._warm: set[tuple] = set()  # (robot, operation, argument layout) already run once in a thread

    def close(self) -> None:
        self.executor.shutdown(wait=False, cancel_futures=True)

    async def run(self, fn: Callable[..., Any], *args: Any) -> Any:
        return await asyncio.get_running_loop().run_in_executor(self.executor, fn, *args)

    # -- models ----------------------------------------------------------------------------------------------
    def record(self, rid: str) -> RobotRecord:
        rec = self.store.get(rid)
        if rec is None:
            raise ApiError(404, f"robot: no robot with id {rid!r}", code="not_found", field="robot")
        return rec

    @staticmethod
    def scene_key(args: dict[str, Any]) -> tuple:
        """The part of a request that selects a reduced model: its canonical locked set (() for none)."""
        locked = args.get("locked")
        return locked_key(locked) if locked else ()

    def loaded(self, rid: str, locked: tuple = ()) -> Loaded:
        """Robot ``rid`` (404 if unknown) with the joints of ``locked`` (a :func:`locked_key`) held still: the
        full model from the cache or the URDF, then the reduced one from the cache or ``lock_joints`` (a bad
        joint name or value is a 422 naming it). Runs in a worker thread: it may parse a URDF."""
        # A robot deleted through another server process must not keep answering from this one's cache.
        if not self.store.exists(rid):
            self.cache.discard(rid)
            raise ApiError(404, f"robot: no robot with id {rid!r}", code="not_found", field="robot")

        def load() -> Loaded:
            return Loaded.of(load_model(self.record(rid)))

        if not locked:
            return self.cache.get_or_load((rid, ()), load)

        def reduce() -> Loaded:  # (a cached reduced model is used even when the full one was evicted)
            full = self.cache.get_or_load((rid, ()), load)
            try:
                return Loaded.of(reduce_model(full.model, locked))
            except ValueError as e:  # InputError: "locked: no movable joint named 'x'; ..."
                raise bad_input(str(e), field_of(str(e)) or "locked") from None

        return self.cache.get_or_load((rid, locked), reduce)

    def model(self, rid: str, locked: tuple = ()):
        """The compiled model of robot ``rid`` (see :meth:`loaded`)."""
        return self.loaded(rid, locked).model

    # -- dynamics --------------------------------------------------------------------------------------------
    def _layout(self, op: Operation, rid: str, args: dict[str, Any]) -> tuple:
        """What selects a compiled specialisation: dimensions of the states, which keywords are given."""
        return (rid, self.scene_key(args), op.name, tuple(args[s].ndim for s in op.states),
                tuple(k for k in op.keywords if args.get(k) is not None))

    def can_inline(self, op: Operation, rid: str, args: dict[str, Any]) -> bool:
        """True when this call has run before (compiled) and its model is in memory: microseconds of work."""
        return (self._layout(op, rid, args) in self._warm
                and self.cache.peek((rid, self.scene_key(args))) is not None)

    def dynamics(self, op: Operation, rid: str, args: dict[str, Any], deadline: float,
                 budget: float) -> dict[str, Any]:
        """Run ``op`` on one state or a batch, chunked, checking ``deadline`` (time.monotonic) between chunks."""
        entry = self.loaded(rid, self.scene_key(args))
        model = entry.model
        states = [args[name] for name in op.states]
        kwargs = {k: args[k] for k in op.keywords if args.get(k) is not None}
        batch = self._batch_size(op, states, kwargs)
        try:
            if batch is None:
                out = op.func(model, *states, **kwargs)
            else:
                out = self._chunked(op, model, states, kwargs, batch, deadline, budget)
        except ValueError as e:  # the library's InputError / DynamicsError: message names the argument
            raise bad_input(str(e), field_of(str(e))) from None
        out = np.asarray(out)
        if not np.isfinite(out).all():
            raise bad_input(f"{op.answer}: the result is not finite (is a movable joint carrying no mass, "
                            f"or are the inputs extreme?)", op.answer)
        self._warm.add(self._layout(op, rid, args))
        return {op.answer: out, "scene": entry.answer_scene(op.skipped(args, model.gravity))}

    def _batch_size(self, op: Operation, states: list[np.ndarray], kwargs: dict[str, Any]) -> int | None:
        first = states[0]
        if first.ndim < 2:
            return None
        batch = first.shape[0]
        if batch > self.settings.max_batch:
            raise bad_input(f"{op.states[0]}: a batch of {batch} states is over the limit of "
                            f"{self.settings.max_batch} (DYNAMICS_MAX_BATCH); split it", op.states[0])
        for name, arr in zip(op.states[1:], states[1:]):
            if arr.ndim == 2 and arr.shape[0] != batch:
                raise bad_input(f"{name}: expected a batch of {batch} states like {op.states[0]}, "
                                f"got shape {arr.shape}", name)
        f_ext = kwargs.get("f_ext")
        if f_ext is not None and f_ext.ndim == 3 and f_ext.shape[0] != batch:
            raise bad_input(f"f_ext: expected shape ({batch}, nbodies, 6) like {op.states[0]}, got {f_ext.shape}",
                            "f_ext")
        return batch

    def _chunked(self, op, model, states, kwargs, batch, deadline, budget):
        chunk = max(1, CHUNK_WORK // max(1, op.cost(model)))
        if batch <= chunk:
            return op.func(model, *states, **kwargs)
        parts = []
        for start in range(0, batch, chunk):
            if time.monotonic() > deadline:
                raise BudgetExceeded(f"{op.name} of {batch} states", budget,
                                     f"{start} states were done; send smaller batches")
            sl = slice(start, start + chunk)
            part_states = [s[sl] if s.ndim == 2 else s for s in states]
            part_kwargs = {k: (v[sl] if k == "f_ext" and v.ndim == 3 else v) for k, v in kwargs.items()}
            parts.append(op.func(model, *part_states, **part_kwargs))
        return np.concatenate(parts, axis=0)


def operations() -> dict[str, Operation]:
    """The dynamics endpoints, by URL segment. Imported lazily so that the app module imports fast."""
    import dynamics

    def per_body(model) -> int:
        return model.nbodies

    def mass_cost(model) -> int:
        return model.nbodies + model.nv * model.nv // 4  # CRBA's backward pass fills nv^2 entries

    return {
        "inverse-dynamics": Operation("inverse dynamics", dynamics.inverse_dynamics, ("q", "v", "a"),
                                      ("gravity", "f_ext"), "tau", per_body, {"v": "state", "a": "state"}),
        "forward-dynamics": Operation("forward dynamics", dynamics.forward_dynamics, ("q", "v", "tau"),
                                      ("gravity", "f_ext"), "a", mass_cost, {"v": "state", "a": "computed"}),
        "mass-matrix": Operation("mass matrix", dynamics.mass_matrix, ("q",), (), "mass_matrix", mass_cost),
        "gravity-torques": Operation("gravity torques", dynamics.gravity_torques, ("q",), ("gravity",), "tau",
                                     per_body, {"v": "zero", "a": "zero"}),
        "bias-forces": Operation("bias forces", dynamics.bias_forces, ("q", "v"), ("gravity",), "tau", per_body,
                                 {"v": "state", "a": "zero"}),
    }
