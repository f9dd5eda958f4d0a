"""Running one job, part by part, in a job worker process (:mod:`service.jobs.executor`) by calling the library.

A job's items (runs of ``simulate_many``, states of a dynamics batch) are done in parts of about
``DYNAMICS_JOB_PART_SECONDS`` of work: the first part is small, later ones are sized from the measured rate.
Each part is one library call spread over the local cores (``engine="threads"``) or over a Ray cluster
(``engine="ray"``, ``DYNAMICS_RAY_ADDRESS``): ``dynamics.simulate_many`` or ``dynamics.map_batches``. Its result
is written atomically to ``parts/<id>/<lo>-<hi>.npz`` before the progress is recorded, so a job interrupted
anywhere (a SIGKILLed server, a dead worker) resumes after its last finished part, and the parts stacked give
exactly what one call on the whole input gives (every item is computed alone, bit for bit).

A ``simulate_many`` whose contact asks for ``outputs: ["contacts"]`` keeps every run's active contacts per
sample as rows (``contacts.run``, ``contacts.sample``, ... : :func:`service.contact.run_samples`) in its parts and
its result. Their number is known only as the runs end: the result's size limit counts them part by part (a job
past it fails, saying so, before the part is written), and a part holds at most the runs whose fixed-capacity
contact arrays fit :data:`PART_CONTACT_BYTES`.

Between parts the runner records progress and, by the same write, learns whether the job is still its own
(cancelled, deleted or handed to another server: it stops). Within a part the library's progress callback
updates ``done`` at most every :data:`PROGRESS_EVERY` seconds.
"""

from __future__ import annotations

import json
import logging
import re
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np

from ..errors import InvalidInput, figure, storage_full
from ..library import lib
from ..models import ModelCache, cached, load_model
from ..settings import Settings
from ..sim.job import samples
from .. import contact as contacts
from .. import torque as torques
from ..codec import finite_report
from ..store import RobotStore
from .db import JobDB, JobRecord
from .files import JobFiles, Stacked, member_shapes, read_member, read_npz, write_npz

log = logging.getLogger("service.jobs")

#: seconds between progress writes inside a part
PROGRESS_EVERY = 0.5
#: size of the first part (items), before any rate is known
FIRST_PART = {"simulate_many": 8, "dynamics": 4096}
#: memory for one part's contacts per sample (the library's fixed-capacity arrays: T samples x K rows per run):
#: the part size is capped to fit
PART_CONTACT_BYTES = 256 * 1024 * 1024
#: numbers a run holds per sample and contact row while its part is stacked: its own ContactSamples (15), the
#: stacked copy (15) and at most the flattened active rows (16)
HELD_PER_ROW = 48
_PART_NAME = re.compile(r"^(\d+)-(\d+)\.npz$")

# -- the kinds of job ----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Dynamics:
    """A batched dynamics function over rows of its state arrays, in parts through ``dynamics.map_batches``."""
    function: str             # inverse_dynamics
    states: tuple[str, ...]   # (q, v, a)
    answer: str               # tau

    def total(self, model, inputs: dict[str, np.ndarray], spec: dict[str, Any]) -> int:
        return int(inputs[self.states[0]].shape[0]) if inputs[self.states[0]].ndim == 2 else 1

    def result_bytes(self, model, total: int, spec: dict[str, Any]) -> int:
        return 8 * total * (model.nv * model.nv if self.answer == "mass_matrix" else model.nv)

    def run(self, model, inputs, spec, lo, hi, engine, progress) -> dict[str, Any]:
        fn = getattr(lib(), self.function)
        arrays = [np.atleast_2d(inputs[name])[lo:hi] for name in self.states]
        kwargs = {"gravity": np.asarray(spec["options"]["gravity"])} if spec["options"].get("gravity") else {}
        out = lib().map_batches(fn, model, *arrays, progress=progress, **engine, **kwargs)
        return {self.answer: out}

    def assemble(self, parts: list[Path], total: int) -> dict[str, Any]:
        first = read_member(parts[0], self.answer)
        return {self.answer: Stacked((total, *first.shape[1:]), first.dtype,
                                     (read_member(p, self.answer) for p in parts))}


class SimulateMany:
    """Runs of ``dynamics.simulate_many``: q0 (B, nq), v0 (B, nv) (either may be one row), a torque spec whose
    array fields may hold one row per run (see :data:`service.torque.RUN_NDIM`), the simulate options."""

    function = "simulate_many"
    states = ("q0", "v0")

    def total(self, model, inputs, spec) -> int:
        rows = [inputs[n].shape[0] for n in self.states if inputs[n].ndim == 2]
        rows += torques.runs(self.torque_spec(inputs, spec)).values()
        return max(rows, default=1)

    @staticmethod
    def torque_spec(inputs, spec) -> Any:
        """The job's torque spec with its arrays (kept in the inputs file) put back, or None."""
        return None if spec.get("torque") is None else torques.join(spec["torque"], inputs)

    def result_bytes(self, model, total: int, spec: dict[str, Any]) -> int:
        o = spec["options"]
        count = samples(o["duration"], o.get("sample_dt"), o.get("dt"), o.get("integrator"))
        return 8 * total * count * (model.nq + 2 * model.nv + _sensitivity_numbers(model, o, spec))


    def run(self, model, inputs, spec, lo, hi, engine, progress) -> dict[str, Any]:
        options = dict(spec["options"])
        duration = options.pop("duration")
        if options.get("contact") is not None:  # the HTTP spec, as /simulate's (service.contact)
            options["contact"] = contacts.build(options["contact"])
        q0, v0 = (np.broadcast_to(inputs[n], (self.total(model, inputs, spec), inputs[n].shape[-1]))[lo:hi]
                  for n in self.states)
        out = lib().simulate_many(model, q0, v0, duration, torque=torques.for_runs(self.torque_spec(inputs, spec), lo, hi),
                                  progress=progress, **engine, **options)
        reports = [dict(finite_report(r), run=lo + k) for k, r in enumerate(out.reports)]
        extra = {} if out.sensitivities is None else {"sensitivities": out.sensitivities}
        if "contacts" in (spec["options"].get("contact") or {}).get("outputs", ()):
            rows = contacts.run_samples(out.contacts, lo)
            rows["contacts.pairs"] = np.array(json.dumps(rows["contacts.pairs"]))  # (a JSON member, as reports)
            extra.update(rows)
        return {"t": out.t, "q": out.q, "v": out.v, "tau": out.tau, "counts": out.counts,
                "reports": np.array(json.dumps(reports)), **extra}

    def assemble(self, parts: list[Path], total: int) -> dict[str, Any]:
        grids = [read_member(p, "t") for p in parts]
        t = max(grids, key=len)
        T = len(t)

        def padded(name):  # a part whose runs all stopped early has fewer samples: NaN after them
            rest = read_member(parts[0], name).shape[2:]
            chunks = (np.pad(x, ((0, 0), (0, T - x.shape[1])) + ((0, 0),) * len(rest), constant_values=np.nan)
                      for x in (read_member(p, name) for p in parts))
            return Stacked((total, T, *rest), np.float64, chunks)

        reports = [r for p in parts for r in json.loads(str(read_member(p, "reports")))]
        extra = {"sensitivities": padded("sensitivities")} if _has_member(parts[0], "sensitivities") else {}
        return {"t": t, "q": padded("q"), "v": padded("v"), "tau": padded("tau"),
                "counts": np.concatenate([read_member(p, "counts") for p in parts]),
                "reports": np.array(json.dumps(reports)), **extra, **_stacked_contacts(parts)}


def _has_member(path: Path, name: str) -> bool:
    with np.load(path, allow_pickle=False) as npz:
        return name in npz.files


def _stacked_contacts(parts: list[Path]) -> dict[str, Any]:
    """The parts' contact rows (``contacts.run``, ``sample``, ... : already in run order) streamed one after
    the other, and the pair names (every run has the same; none when no run kept contacts)."""
    shapes = [member_shapes(p) for p in parts]
    if "contacts.run" not in shapes[0]:
        return {}
    def stacked(name: str) -> Stacked:  # (a function: each generator reads its own member)
        shape, dtype = shapes[0][name]
        n = sum(s[name][0][0] for s in shapes)
        return Stacked((n, *shape[1:]), dtype, (read_member(p, name) for p in parts))

    out: dict[str, Any] = {name: stacked(name) for name in contacts.RUN_MEMBERS}
    pairs = (json.loads(str(read_member(p, "contacts.pairs"))) for p in parts)
    out["contacts.pairs"] = np.array(json.dumps(next((x for x in pairs if x is not None), [])))
    return out


def contact_bytes(shapes: dict[str, tuple[tuple, Any]]) -> int:
    """Bytes of the contact rows among arrays given by {name: (shape, dtype)} (0 without contact outputs)."""
    return sum(int(np.prod(shapes[n][0])) * np.dtype(shapes[n][1]).itemsize
               for n in contacts.RUN_MEMBERS if n in shapes)


def contact_part_cap(result: dict[str, Any]) -> float:
    """The most runs a part may hold so that the library's fixed-capacity contact arrays of the part (T samples
    x K = the scene's ``max_contacts`` rows per run, read from the reports) stay within
    :data:`PART_CONTACT_BYTES`; unbounded (inf) without contact outputs."""
    if "contacts.run" not in result:
        return float("inf")
    reports = json.loads(str(result["reports"]))
    K = max((r.get("contact", {}).get("max_contacts", 0) for r in reports), default=0)
    return max(1, PART_CONTACT_BYTES // max(1, 8 * HELD_PER_ROW * len(result["t"]) * K))


def _sensitivity_numbers(model, options: dict[str, Any], spec: dict[str, Any]) -> int:
    """Numbers per sample of the sensitivities a run asks for (2 nv rows, a column per x0 coordinate and per
    parameter; a table's "tau": one per entry)."""
    names = options.get("sensitivities")
    names = ("x0",) if names is True else (names or ())
    torque = spec.get("torque") or {}
    rows = int(np.size(torque.get("t", [0]))) if torque.get("type") == "table" else 1
    cols = {"x0": 2 * model.nv, "tau": model.nv * rows}
    return 2 * model.nv * sum(cols.get(name, model.nv) for name in set(names))


KINDS: dict[str, Any] = {
    "simulate_many": SimulateMany(),
    "inverse_dynamics": Dynamics("inverse_dynamics", ("q", "v", "a"), "tau"),
    "forward_dynamics": Dynamics("forward_dynamics", ("q", "v", "tau"), "a"),
    "mass_matrix": Dynamics("mass_matrix", ("q",), "mass_matrix"),
}


# -- the worker process's side -------------------------------------------------------------------------------
_process: dict[str, Any] = {}  # per worker process: the database connection, the robot store, the model cache


def _state(files: JobFiles, settings: Settings) -> tuple[JobDB, RobotStore, ModelCache]:
    if "db" not in _process:
        _process["db"] = JobDB(files.db)
        _process["store"] = RobotStore(settings.store_dir, settings.robots_dir)
        _process["models"] = ModelCache(8)
    return _process["db"], _process["store"], _process["models"]


def model_of(store: RobotStore, models: ModelCache, robot: str, locked: tuple):
    record = store.get(robot)
    if record is None:
        raise ValueError(f"robot: {robot!r} was deleted before the job ran")
    return cached(models, robot, locked, lambda: load_model(record.urdf, record.floating_base))


def parts_done(folder: Path) -> list[tuple[int, int]]:
    """[(lo, hi)] of the parts on disk that follow each other from item 0 (a crash leaves whole files only; a
    runner orphaned by a killed server may have left a part cut elsewhere, which is then skipped)."""
    ends: dict[int, int] = {}
    for p in folder.glob("*.npz"):
        if m := _PART_NAME.match(p.name):
            ends[int(m[1])] = max(ends.get(int(m[1]), 0), int(m[2]))
    chain, at = [], 0
    while at in ends:
        chain.append((at, ends[at]))
        at = ends[at]
    return chain


def run_job(files: JobFiles, job_id: str, boot: str) -> None:
    """Entry point in a job worker process: run ``job_id`` if it is still running under ``boot``."""
    settings = Settings.from_env()
    db, store, models = _state(files, settings)
    job = db.get(job_id)
    if job is None or job.status != "running" or job.boot != boot:
        return
    try:
        _run(files, settings, db, store, models, job, boot)
    except Exception as e:  # noqa: BLE001 - a job must end with a reason, never silently
        now = db.get(job_id)
        if now is None or now.status != "running" or now.boot != boot:  # cancelled or deleted under our feet
            files.remove(job_id, keep_result=now is not None and now.status == "done")
        # the files go before the record says "failed": whoever sees the failure sees no leftover parts (a crash
        # in between leaves a running job without files, which its next attempt fails the same way)
        elif isinstance(e, ValueError):  # the library's InputError (names the argument) and our own refusals
            contact = (now.spec.get("options") or {}).get("contact") is not None
            files.remove(job_id)
            db.fail(job_id, contacts.qualify(str(e)) if contact else str(e), boot)
        elif (full := storage_full(e, f"the job store {files.root}")) is not None:
            files.remove(job_id)  # (also: the record's update needs room)
            db.fail(job_id, full.detail, boot)
        else:
            log.error("job %s failed:\n%s", job_id, traceback.format_exc())
            files.remove(job_id)
            db.fail(job_id, f"internal error: {type(e).__name__}: {e}", boot)


def _run(files: JobFiles, settings: Settings, db: JobDB, store: RobotStore, models: ModelCache, job: JobRecord,
         boot: str) -> None:
    kind = KINDS[job.kind]
    locked = tuple((name, tuple(v)) for name, v in job.spec.get("locked", []))
    model = model_of(store, models, job.robot, locked)
    inputs = read_npz(files.inputs(job.id))
    engine = {"engine": "ray", "ray_address": settings.ray_address} if settings.ray_address else {"engine": "threads"}
    folder = files.parts(job.id)
    folder.mkdir(parents=True, exist_ok=True)
    done_parts = parts_done(folder)
    lo = done_parts[-1][1] if done_parts else 0
    seconds = job.compute_seconds
    size = FIRST_PART["simulate_many" if job.kind == "simulate_many" else "dynamics"]
    estimate = kind.result_bytes(model, job.total, job.spec)  # (without the contact rows: known as they come)
    kept = sum(contact_bytes(member_shapes(folder / f"{a}-{b}.npz")) for a, b in done_parts)
    while lo < job.total:
        hi = min(job.total, lo + size)
        t0 = time.perf_counter()
        result = kind.run(model, inputs, job.spec, lo, hi, engine, _progress_writer(db, job.id, boot, lo, seconds))
        elapsed = time.perf_counter() - t0
        if not db.owns(job.id, boot):  # cancelled, deleted or handed on meanwhile: leave it
            return
        kept += contact_bytes({k: (np.shape(v), np.asarray(v).dtype) for k, v in result.items()})
        if estimate + kept > settings.max_job_result_bytes:
            raise ValueError(_over_limit(kept, estimate, hi, settings.max_job_result_bytes))
        write_npz(folder / f"{lo}-{hi}.npz", result)
        seconds += elapsed
        if not db.progress(job.id, boot, hi, seconds):
            return
        rate = (hi - lo) / max(elapsed, 1e-6)
        size = int(min(4 * size, max(1, rate * settings.job_part_seconds), contact_part_cap(result)))
        lo = hi
    parts = [folder / f"{a}-{b}.npz" for a, b in parts_done(folder)]
    nbytes = write_npz(files.result(job.id), kind.assemble(parts, job.total))
    if db.finish(job.id, boot, nbytes, seconds):
        files.remove(job.id, keep_result=True)
    else:  # cancelled meanwhile
        files.remove(job.id)


def _over_limit(kept: int, estimate: int, done: int, limit: int) -> str:
    return (f"options.contact.outputs: the contacts per sample of runs 0-{done - 1} take {figure(kept)} bytes, "
            f"which with the rest of the result (about {figure(estimate)} bytes) is over the limit of {limit} bytes "
            f"(DYNAMICS_MAX_JOB_RESULT_BYTES); split the job into fewer runs, sample less often (sample_dt) or "
            f"leave out outputs ['contacts']")


def _progress_writer(db: JobDB, job_id: str, boot: str, base: int, seconds: float) -> Callable[[int, int], None]:
    last = [time.monotonic()]

    def progress(done: int, total: int) -> None:
        now = time.monotonic()
        if now - last[0] >= PROGRESS_EVERY:
            last[0] = now
            db.progress(job_id, boot, base + done, seconds)

    return progress


def check_inputs(kind_name: str, model, inputs: dict[str, np.ndarray], spec: dict[str, Any]) -> Optional[str]:
    """At submission: the first thing wrong with the inputs' shapes (named), or None. The library checks
    values (finiteness, quaternions) when the job runs; shapes are cheap to check now and catch most mistakes."""
    kind = KINDS[kind_name]
    sizes = {"q": model.nq, "q0": model.nq, "v": model.nv, "v0": model.nv, "a": model.nv, "tau": model.nv}
    total = kind.total(model, inputs, spec)
    for name in kind.states:
        if name not in inputs:
            return f"inputs.{name}: missing (required for {kind_name})"
        x, n = inputs[name], sizes[name]
        one_row = x.ndim == 1 and x.shape == (n,) and kind_name == "simulate_many"  # shared by every run
        if not (one_row or x.shape == (total, n)):
            rows = f"({n},) or ({total}, {n})" if kind_name == "simulate_many" else f"(B, {n})"
            return f"inputs.{name}: expected shape {rows}, got {x.shape}"
    if kind_name == "simulate_many" and spec["options"].get("contact") is not None:
        contact = spec["options"]["contact"]
        try:  # the declarations the library refuses and unknown frames (a 422 now, not when the job runs)
            contacts.build(contact)
            contacts.check_frames(model, contact)
        except InvalidInput as e:
            return f"options.{e.detail}"
    if kind_name == "simulate_many":  # the first run's torque, as /simulate would read it (a 422 now, not later)
        try:
            torques.check(model, SimulateMany.torque_spec(inputs, spec), total)
        except InvalidInput as e:
            return f"inputs.{e.detail}"
        except ValueError as e:  # the library's InputError: "torque.kp: expected ..."
            return f"inputs.{e}"
    return None
