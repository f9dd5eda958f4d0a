"""Where the service calls the library: the operations, off the event loop, within a wall-time budget.

Two kinds of work, two mechanisms:

* Dynamics calls (inverse/forward dynamics, mass matrix, ...) run in a small thread pool, one library call per
  request: the library checks the arguments (its errors name them) and splits a batch over its own threads.
  A batch runs inside the request's deadline (:func:`within`): the library looks at the clock between pieces of
  a few milliseconds and stops, so a request past its budget frees its threads at once (504).
* A simulation is one library call whose cost the caller controls (duration, tolerances, a stiff system). It
  runs in a worker process (:mod:`service.sim.pool`) inside the request's deadline: the C++ core checks the
  clock in its integration loop and stops (504), and a worker still busy shortly past the deadline is killed.
  The process also keeps a crash of the core away from the server (see docs/architecture.md, "Simulations").
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import math
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Callable, Iterator, NamedTuple, Optional

import numpy as np

from .errors import (BudgetExceeded, Failed, InvalidInput, NotOffered, Problem, TooLarge, Unavailable, field_of,
                     figure)
from .codec import wants_npz
from .contact import check_frames
from .library import lib, parallel
from .models import Models, locked_key
from .scene import Terms, simulation_scene, skipped
from . import schemas
from .schemas import SimulateRequest
from .settings import Settings
from .sim.job import Job, build_job
from .sim.job import samples as sim_samples
from .sim.pool import PoolBusy, PoolTimeout, SimPool, WorkerCrashed

# Requests with bodies up to this size may run on the event loop (see service.routes.dynamics)...
INLINE_BYTES = 2048
# ... when their answer holds at most this many numbers (a 128-joint mass matrix, 16k numbers, takes ~1 ms of
# CRBA and encoding: four clients sending those pushed /v1/health from 1 ms to 224 ms)
INLINE_NUMBERS = 512
# Bytes per number of an answer, to estimate its size before computing it: .npz (float64) and JSON (orjson
# writes at most 24 characters and a comma per float64, ~20 on average)
NPZ_BYTES_PER_NUMBER = 8
JSON_BYTES_PER_NUMBER = 21


@dataclass(frozen=True)
class Budget:
    """A request's wall-time budget: ``seconds``, ending at ``deadline`` on :func:`time.monotonic`'s clock."""
    seconds: float
    deadline: float

    @classmethod
    def starting_now(cls, seconds: float) -> "Budget":
        return cls(seconds, time.monotonic() + seconds)

    def left(self) -> float:
        return max(0.0, self.deadline - time.monotonic())


@contextlib.contextmanager
def within(budget: Budget, what: str) -> Iterator[None]:
    """The one place a request's deadline reaches the library: batched calls inside ``dynamics.parallel.deadline``
    check the clock between pieces of ~2 ms and raise ``DeadlineExceeded``, answered here as a 504."""
    try:
        with parallel().deadline(budget.deadline):
            yield
    except lib().DeadlineExceeded:
        raise BudgetExceeded(what, budget.seconds, "send smaller batches") from None


def check_time(budget: Budget, what: str, hint: str = "send smaller batches") -> None:
    """A 504 when ``budget`` is spent: between the stages of a request (queued, decoded, computed, encoded)."""
    if budget.left() <= 0:
        raise BudgetExceeded(what, budget.seconds, hint)


def answer_bytes(numbers: int, npz: bool) -> int:
    return numbers * (NPZ_BYTES_PER_NUMBER if npz else JSON_BYTES_PER_NUMBER)


def check_answer_size(numbers: int, npz: bool, settings: Settings, what: str) -> int:
    """The estimated size of an answer of ``numbers`` float64, or a 413 naming the limit before any work."""
    size = answer_bytes(numbers, npz)
    limit, env = (settings.max_answer_bytes, "DYNAMICS_MAX_ANSWER_BYTES") if npz else \
        (settings.max_json_answer_bytes, "DYNAMICS_MAX_JSON_ANSWER_BYTES")
    if size > limit:
        hint = "send smaller batches" if npz else \
            "ask for .npz (Accept: application/x-npz, 8 bytes a number) or send smaller batches"
        raise TooLarge(f"answer: {what} is {figure(numbers)} numbers, about {figure(size)} bytes as "
                       f"{'.npz' if npz else 'JSON'}, over the limit of {limit} bytes ({env}); {hint}", "answer")
    return size


class Endpoint(NamedTuple):
    """How an operation is offered over HTTP (``POST /v1/robots/{id}/<its key in OPERATIONS>``)."""
    request: Any   # the request schema (service.schemas)
    answer: Any    # the answer schema
    summary: str   # one line for the OpenAPI document


@dataclass(frozen=True)
class Operation:
    """One dynamics endpoint: the library function, its state arguments, its keyword arguments, its answer."""
    name: str                  # for messages: "inverse dynamics"
    function: str              # the library's function: "inverse_dynamics"
    states: tuple[str, ...]    # positional state arguments, one state or a batch along axis 0
    keywords: tuple[str, ...]  # optional keyword arguments (gravity, f_ext)
    answer: str                # key of the answer: "tau", "a", "mass_matrix"
    terms: Optional[Terms] = None  # where v and a come from, for the scene's "skipped" (service.scene)
    #: an answer of several parts (kinematics, centre of mass, inverse kinematics): ``call(model, args)`` returns
    #: them by key, in place of ``{answer: function(model, *states, **keywords)}`` (see service.kinematics)
    call: Optional[Callable[[Any, dict[str, Any]], dict[str, Any]]] = None
    #: numbers of the answer per state, ``per_state(model, args)``: a batch whose answer would be larger than
    #: DYNAMICS_MAX_(JSON_)ANSWER_BYTES is refused before it is computed (None: nv, or nv^2 for a matrix)
    per_state: Optional[Callable[[Any, dict[str, Any]], int]] = None
    #: arguments that may carry a batch besides the states, with the dimensions of one item ({"target": 2})
    batched: tuple[tuple[str, int], ...] = ()
    #: iterative work whose cost the request sets (inverse kinematics): run within the budget even for one state
    iterative: bool = False
    #: its endpoint: request and answer schemas, summary (the URL segment is its key in the table)
    endpoint: Optional[Endpoint] = None


#: the dynamics endpoints, by URL segment
OPERATIONS: dict[str, Operation] = {
    "inverse-dynamics": Operation("inverse dynamics", "inverse_dynamics", ("q", "v", "a"), ("gravity", "f_ext"),
                                  "tau", {"v": "state", "a": "state"},
        endpoint=Endpoint(schemas.InverseDynamicsRequest, schemas.TauAnswer,
                          "tau = ID(q, v, a) by RNEA")),
    "forward-dynamics": Operation("forward dynamics", "forward_dynamics", ("q", "v", "tau"), ("gravity", "f_ext"),
                                  "a", {"v": "state", "a": "computed"},
        endpoint=Endpoint(schemas.ForwardDynamicsRequest, schemas.AccelerationAnswer,
                          "a = FD(q, v, tau) by ABA")),
    "mass-matrix": Operation("mass matrix", "mass_matrix", ("q",), (), "mass_matrix",
        endpoint=Endpoint(schemas.MassMatrixRequest, schemas.MassMatrixAnswer,
                          "M(q) by CRBA")),
    "gravity-torques": Operation("gravity torques", "gravity_torques", ("q",), ("gravity",), "tau",
                                 {"v": "zero", "a": "zero"},
        endpoint=Endpoint(schemas.GravityTorquesRequest, schemas.TauAnswer,
                          "g(q) = ID(q, 0, 0)")),
    "bias-forces": Operation("bias forces", "bias_forces", ("q", "v"), ("gravity",), "tau",
                             {"v": "state", "a": "zero"},
        endpoint=Endpoint(schemas.BiasForcesRequest, schemas.TauAnswer,
                          "h(q, v) = ID(q, v, 0)")),
    "coriolis-matrix": Operation("Coriolis matrix", "coriolis_matrix", ("q", "v"), (), "coriolis_matrix",
                                 per_state=lambda model, args: model.nv * model.nv,
        endpoint=Endpoint(schemas.CoriolisMatrixRequest, schemas.CoriolisMatrixAnswer,
                          "C(q, v): C v + g = h, dM/dt - 2C skew-symmetric")),
    "kinetic-energy": Operation("kinetic energy", "kinetic_energy", ("q", "v"), (), "kinetic_energy",
        endpoint=Endpoint(schemas.KineticEnergyRequest, schemas.KineticEnergyAnswer,
                          "T = 1/2 v^T M(q) v")),
    "potential-energy": Operation("potential energy", "potential_energy", ("q",), ("gravity",), "potential_energy",
        endpoint=Endpoint(schemas.PotentialEnergyRequest, schemas.PotentialEnergyAnswer,
                          "U(q) = -sum m_i g . c_i")),
}


def _numbers_per_state(op: Operation, model, args: dict[str, Any]) -> int:
    """Numbers of the answer per state (the operation's own count, else nv or nv^2)."""
    if op.per_state is not None:
        return op.per_state(model, args)
    return model.nv * model.nv if op.answer == "mass_matrix" else model.nv


def call(op: Operation, model, args: dict[str, Any]) -> dict[str, Any]:
    """The library's answer to ``op`` on ``args``, by key (arguments not given, None, are left to its defaults)."""
    if op.call is not None:
        return op.call(model, args)
    kwargs = {k: args[k] for k in op.keywords if args.get(k) is not None}
    return {op.answer: getattr(lib(), op.function)(model, *[args[s] for s in op.states], **kwargs)}


def _finite(out: Any) -> bool:
    """False for an array of floats or a float holding nan or inf; True for anything else (names, reports)."""
    if isinstance(out, np.ndarray):
        return out.dtype.kind != "f" or bool(np.isfinite(out).all())
    return not isinstance(out, float) or math.isfinite(out)


def _columns(model, outputs: Optional[list[str]]) -> int:
    """Numbers per sample of a simulation answer: t and the asked outputs (default q, v, tau)."""
    outputs = ("q", "v", "tau") if outputs is None else outputs
    size = {"q": model.nq, "v": model.nv, "tau": model.nv,
            "lambda": sum(c.rows for c in getattr(model, "constraints", ()))}
    return 1 + sum(size[o] for o in set(outputs))


def _sensitivity_columns(model, req: SimulateRequest) -> int:
    """Numbers per sample of the sensitivities asked for: 2 nv rows times a column per x0 coordinate and per
    parameter (a table's "tau": one per entry). Unknown names count nothing here: the library refuses them."""
    names = ("x0",) if req.sensitivities is True else (req.sensitivities or ())
    nv = model.nv
    table_rows = int(np.size(req.torque.t)) if getattr(req.torque, "type", "") == "table" else 1
    cols = {"x0": 2 * nv, "tau": nv * table_rows}
    return 2 * nv * sum(cols.get(name, nv) for name in set(names))


class Compute:
    """The thread pools, the simulation workers and the deadline logic, shared by all requests of one process."""

    def __init__(self, settings: Settings, models: Models, pool: Optional[SimPool]):
        self.settings = settings
        self.models = models
        self.pool = pool
        self.executor = ThreadPoolExecutor(max_workers=settings.compute_threads, thread_name_prefix="dynamics")
        # threads that wait for a simulation worker's answer (the work itself runs in the worker process)
        self.waiters = ThreadPoolExecutor(max_workers=max(1, 4 * settings.sim_workers), thread_name_prefix="sim-wait")

    def close(self) -> None:
        self.executor.shutdown(wait=False, cancel_futures=True)
        self.waiters.shutdown(wait=False, cancel_futures=True)

    async def run(self, fn: Callable[..., Any], *args: Any) -> Any:
        return await asyncio.get_running_loop().run_in_executor(self.executor, fn, *args)

    async def run_within(self, budget: Budget, fn: Callable[..., Any], *args: Any) -> Any:
        """:meth:`run` whose wait for a free thread counts in ``budget``: a request queued past it is a 504
        before any of its work starts."""
        def start() -> Any:
            check_time(budget, "the request, waiting for a compute thread,", "retry when the server is less busy")
            try:
                return fn(*args)
            except Problem as e:  # (its traceback's frames would hold the request's arrays until a gc pass)
                problem = e.with_traceback(None)
                problem.__context__ = None
            raise problem
        return await self.run(start)

    # -- dynamics --------------------------------------------------------------------------------------------
    def can_inline(self, op: Operation, rid: str, args: dict[str, Any]) -> bool:
        """True when this call's model is in memory and its answer small (one state): microseconds of work, fit
        for the event loop."""
        if op.iterative or any(
                args.get(s) is not None and args[s].ndim != 1 for s in op.states):
            return False
        entry = self.models.cache.peek((rid, locked_key(args.get("locked"))))
        return entry is not None and _numbers_per_state(op, entry.model, args) <= INLINE_NUMBERS

    def dynamics(self, op: Operation, rid: str, args: dict[str, Any], budget: Budget,
                 accept: Optional[str] = None) -> dict[str, Any]:
        """Run ``op`` on one state or a batch of robot ``rid``; a batch within ``budget``. The answer's size
        (encoded as ``accept`` asks) is checked against the limits first."""
        entry = self.models.loaded(rid, locked_key(args.get("locked")))
        batch = self._batch_size(op, args)
        what = f"{op.name} of {batch or 1} state{'s' if batch else ''}"
        # (one state too: a request may name every frame many times)
        check_answer_size((batch or 1) * _numbers_per_state(op, entry.model, args), wants_npz(accept),
                          self.settings, what)
        if batch is None and not op.iterative:  # one state cannot overrun a budget, and the deadline costs ~2 us
            result = call(op, entry.model, args)
        else:
            with within(budget, what):
                result = call(op, entry.model, args)
        for key, out in result.items():
            if not _finite(out):
                raise InvalidInput(f"{key}: the result is not finite (is a movable joint carrying no mass, or are "
                                   f"the inputs extreme?)", key)
        return {**result, "scene": entry.scene.answer(skipped(op.terms, args, entry.model.gravity))}

    def _batch_size(self, op: Operation, args: dict[str, Any]) -> Optional[int]:
        """The largest batch among the arguments (None: one state), within the service's DYNAMICS_MAX_BATCH.

        Only this policy limit is checked here: shapes, finiteness and matching batch sizes are the library's.
        """
        sizes = [(args[name].shape[0], name) for name in op.states
                 if args[name] is not None and args[name].ndim == 2]
        for name, ndim in (("f_ext", 2), *op.batched):
            x = args.get(name)
            if isinstance(x, np.ndarray) and x.ndim > ndim:
                sizes.append((x.shape[0], name))
        if not sizes:
            return None
        batch, name = max(sizes)
        if batch > self.settings.max_batch:
            raise InvalidInput(f"{name}: a batch of {batch} states is over the limit of {self.settings.max_batch} "
                               f"(DYNAMICS_MAX_BATCH); split it", name)
        return batch

    # -- simulation ------------------------------------------------------------------------------------------
    def require_simulation(self) -> None:
        """A 501 on a server without simulation workers (DYNAMICS_SIM_WORKERS=0). A request right after the
        start needs no other wait than :meth:`SimPool.run`'s for an idle worker (one importing the library)."""
        if self.pool is None:
            raise NotOffered("simulate: not available on this server (DYNAMICS_SIM_WORKERS=0)")

    def simulation_job(self, rid: str, req: SimulateRequest, accept: Optional[str] = None
                       ) -> tuple[Job, dict[str, Any]]:
        """The job for a simulation worker, and the scene of its answer. An unknown robot (404), a bad locked
        set (422) and an answer over the size limit (413) are refused here, before a process is involved; the
        worker builds the same model."""
        locked = locked_key(req.locked)
        entry = self.models.loaded(rid, locked)
        record = entry.record or self.models.record(rid)  # (the cached record: no disk read per request)
        job = build_job(record, locked, req, self.settings)  # (its step and sample limits first)
        check_frames(entry.model, job.contact)
        samples = sim_samples(req.duration, req.sample_dt, req.dt, req.integrator)
        check_answer_size(samples * (_columns(entry.model, req.outputs) + _sensitivity_columns(entry.model, req)),
                          wants_npz(accept), self.settings,
                          f"a trajectory of {samples} samples")
        return job, simulation_scene(entry.scene, entry.model.gravity, req.gravity)

    async def simulate(self, job: Job, budget: Budget, accept: Optional[str] = None) -> tuple[dict[str, Any], float]:
        """The trajectory of ``job`` (arrays and report), computed by a worker process within ``budget``, and the
        seconds the library call took there. Its active contacts (asked by the contact's outputs: their count is
        known only now) are checked against the answer's size limit with the rest."""
        trajectory, seconds = await asyncio.get_running_loop().run_in_executor(self.waiters, self._simulate, job,
                                                                                budget)
        contacts = sum(v.size for k, v in trajectory.items() if k.startswith("contacts.") and isinstance(v, np.ndarray))
        if contacts:
            numbers = contacts + sum(v.size for v in trajectory.values() if isinstance(v, np.ndarray))
            check_answer_size(numbers, wants_npz(accept), self.settings,
                              f"a trajectory with {trajectory['contacts.sample'].shape[0]} contacts")
        return trajectory, seconds

    def _simulate(self, job: Job, budget: Budget) -> tuple[dict[str, Any], float]:
        try:
            outcome = self.pool.run(dataclasses.replace(job, deadline=budget.deadline), budget.deadline)
        except PoolTimeout:
            raise BudgetExceeded(f"the simulation of {job.duration:g} s", budget.seconds,
                                 "shorten the duration, loosen rtol/atol or use a larger dt") from None
        except PoolBusy as e:
            raise Unavailable(f"simulate: {e}; retry shortly", headers={"Retry-After": "1"}) from None
        except WorkerCrashed as e:
            raise Failed(f"simulate: {e}", code="worker_crashed") from None
        if outcome.deadline:  # the core stopped the run at the deadline itself (its worker stays)
            raise BudgetExceeded(f"the simulation of {job.duration:g} s", budget.seconds,
                                 "shorten the duration, loosen rtol/atol or use a larger dt")
        if outcome.input_error is not None:  # the library's InputError, raised in the worker
            raise InvalidInput(outcome.input_error, field_of(outcome.input_error))
        if outcome.error is not None:
            raise Failed(f"simulate: {outcome.error}")
        return outcome.trajectory, outcome.seconds
