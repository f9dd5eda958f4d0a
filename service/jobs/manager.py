"""What the job routes call: submit (check, store the inputs, queue), status, result, cancel and remove.

Everything here runs in a compute thread (file and database writes), never on the event loop, and never
waits on a job. The limits (``DYNAMICS_MAX_JOB_INPUT_BYTES``, ``_MAX_JOB_RESULT_BYTES``, ``_MAX_JOBS_PER_KEY``,
``_JOB_QUOTA_BYTES``, ``_JOB_EXPIRY``) are checked at submission, so that a job refused is refused at once
with the reason, not after hours in the queue. A job belongs to the key that made it: any other key gets the
same 404 as for a job that does not exist.
"""

from __future__ import annotations

import json
import time
import uuid
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np
from pydantic import TypeAdapter, ValidationError

from .. import errors, schemas
from .. import torque as torques
from ..codec import decode, to_array
from ..errors import InvalidInput, NotFound, Problem, TooLarge, figure, storage_full
from ..models import Models, locked_key
from ..settings import Settings
from .db import ACTIVE, JobDB, JobRecord
from .executor import Executor
from .files import JobFiles, write_npz
from .runner import KINDS, check_inputs


class NotReady(Problem):
    """The job has no result (yet, or any more)."""


class TooManyJobs(Problem):
    """The key has DYNAMICS_MAX_JOBS_PER_KEY jobs queued or running."""


class QuotaExceeded(Problem):
    """The key's job files would pass DYNAMICS_JOB_QUOTA_BYTES."""


errors.STATUS.update({NotReady: (409, "not_ready"), TooManyJobs: (429, "too_many_jobs"),
                      QuotaExceeded: (507, "quota_exceeded")})

_TORQUE = TypeAdapter(schemas.TorqueSpec)


class Jobs:
    """The job store (database and files) and the executor of one server process."""

    def __init__(self, settings: Settings, models: Models,
                 resolve: Optional[Callable[[str, Optional[str]], str]] = None):
        """``resolve(robot, owner)``: a robot's id from an id or a name as that owner may see it (404 otherwise;
        service.catalog.Catalog.resolve), so that a job reaches only its key's robots and the shared ones."""
        self.settings = settings
        self.models = models
        self.resolve = resolve
        self.files = JobFiles.under(settings.store_dir)
        self.db = JobDB(self.files.db)
        self.executor = Executor(self.files, self.db, settings) if settings.job_workers > 0 else None

    @classmethod
    def start(cls, settings: Settings, models: Models,
              resolve: Optional[Callable[[str, Optional[str]], str]] = None) -> "Jobs":
        jobs = cls(settings, models, resolve)
        if jobs.executor is not None:
            jobs.executor.start()
        return jobs

    def close(self) -> None:
        if self.executor is not None:
            self.executor.close()
        self.db.close()

    # -- submission ------------------------------------------------------------------------------------------
    def submit(self, owner: Optional[str], body: bytes | Path, content_type: Optional[str]) -> dict[str, Any]:
        """Check a job request, store its inputs durably and queue it; its status (202)."""
        owner = owner or ""
        if isinstance(body, Path):
            body = body.read_bytes()
        req = schemas.validate(schemas.JobRequest, _payload(decode(body, content_type,
                                                                   max_unpacked=4 * self.settings.max_job_input_bytes)))
        s = self.settings
        if self.db.active_count(owner) >= s.max_jobs_per_key:
            raise TooManyJobs(f"jobs: this key has {s.max_jobs_per_key} jobs queued or running, the limit "
                              f"(DYNAMICS_MAX_JOBS_PER_KEY); wait for one to finish or cancel one",
                              headers={"Retry-After": "10"})
        options = req.options.model_dump(exclude_none=True)
        locked = locked_key(options.pop("locked", None))
        if self.resolve is not None:
            req = req.model_copy(update={"robot": self.resolve(req.robot, owner or None)})
        model = self.models.loaded(req.robot, locked).model  # 404 for an unknown robot, 422 for a bad locked set
        arrays, spec = self._inputs(req, options, locked)
        problem = check_inputs(req.kind, model, arrays, spec)
        if problem:
            raise InvalidInput(problem, problem.split(":")[0])
        total = KINDS[req.kind].total(model, arrays, spec)
        estimate = KINDS[req.kind].result_bytes(model, total, spec)
        if estimate > s.max_job_result_bytes:
            raise TooLarge(f"inputs: the result would take about {figure(estimate)} bytes, over the limit of "
                           f"{s.max_job_result_bytes} (DYNAMICS_MAX_JOB_RESULT_BYTES); split the job", "inputs")
        used = self.db.bytes_used(owner)
        if used + estimate + len(body) > s.job_quota_bytes:
            raise QuotaExceeded(f"jobs: this key's job inputs and results hold {used} bytes; this job's would pass "
                                f"the quota of {s.job_quota_bytes} (DYNAMICS_JOB_QUOTA_BYTES); delete finished jobs "
                                f"(DELETE /v1/jobs/{{id}})")
        job_id = uuid.uuid4().hex
        try:  # the inputs first (a queued job always has them); on any failure, no file is left behind
            nbytes = write_npz(self.files.inputs(job_id), arrays)
            self.db.create(job_id, owner, req.robot, req.kind, spec, total, nbytes)
        except Exception as e:
            self.files.remove(job_id)
            raise storage_full(e, f"the job store {self.files.root}") or e
        if self.executor is not None:
            self.executor.notify()
        return self.describe(self.db.get(job_id))

    def _inputs(self, req: schemas.JobRequest, options: dict[str, Any],
                locked: tuple) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """The request's inputs -> (arrays for the inputs file, the JSON spec for the database)."""
        kind = KINDS[req.kind]
        allowed = set(kind.states) | ({"torque"} if req.kind == "simulate_many" else set())
        unknown = sorted(set(req.inputs) - allowed)
        if unknown:
            raise InvalidInput(f"inputs.{unknown[0]}: unknown input for {req.kind}; expected {sorted(allowed)}",
                               f"inputs.{unknown[0]}")
        if req.kind == "simulate_many" and "duration" not in options:
            raise InvalidInput("options.duration: missing (required for simulate_many)", "options.duration")
        arrays = {}
        for name in kind.states:
            if name in req.inputs:
                arrays[name] = to_array(req.inputs[name], f"inputs.{name}")
        spec: dict[str, Any] = {"options": {k: (v.tolist() if isinstance(v, np.ndarray) else v)
                                            for k, v in options.items()}, "locked": [list(x) for x in locked]}
        torque = req.inputs.get("torque")
        if torque is not None:
            try:  # the schema of /simulate's torque, and its translation (service.torque) when the job runs
                parsed = _TORQUE.validate_python(torque).model_dump(exclude_none=True)
            except ValidationError as e:
                err = e.errors(include_url=False)[0]
                where = ".".join(["inputs", "torque", *(str(p) for p in err["loc"][1:])])
                raise InvalidInput(f"{where}: {err['msg']}", where) from None
            except InvalidInput as e:  # an array field that is no array ("q_target: expected a number, ...")
                raise InvalidInput(f"inputs.torque.{e.detail}", f"inputs.torque.{e.field}") from None
            spec["torque"], torque_arrays = torques.split(parsed)
            arrays.update(torque_arrays)
        return arrays, spec

    # -- reading ---------------------------------------------------------------------------------------------
    def get(self, owner: Optional[str], job_id: str) -> JobRecord:
        job = self.db.get(job_id) if len(job_id) <= 64 else None
        if job is None or job.owner != (owner or ""):
            raise NotFound(f"job: no job with id {job_id!r}", "job")
        return job

    def status(self, owner: Optional[str], job_id: str) -> dict[str, Any]:
        return self.describe(self.get(owner, job_id))

    def list(self, owner: Optional[str]) -> list[dict[str, Any]]:
        return [self.describe(j) for j in self.db.of_owner(owner or "")]

    def result(self, owner: Optional[str], job_id: str) -> tuple[JobRecord, Path]:
        job = self.get(owner, job_id)
        path = self.files.result(job_id)
        if job.status != "done":
            why = f"; {job.error}" if job.error and job.status == "failed" else ""
            raise NotReady(f"job: {job_id} is {job.status}{why}; its result is served once it is done", "job")
        if not path.is_file():
            raise NotReady(f"job: the result of {job_id} is missing from the store", "job")
        return job, path

    def describe(self, job: JobRecord) -> dict[str, Any]:
        now = time.time()
        running = None
        if job.started is not None:
            running = (job.finished or now) - job.started
        queued = (job.started or job.finished or now) - job.created
        url = f"/v1/jobs/{job.id}"
        return {"id": job.id, "robot": job.robot, "kind": job.kind, "status": job.status,
                "progress": {"done": job.done, "total": job.total, "fraction": job.done / max(job.total, 1)},
                "created": job.created, "started": job.started, "finished": job.finished,
                "timing": {"queued_seconds": queued, "running_seconds": running,
                           "compute_seconds": job.compute_seconds},
                "error": job.error, "attempts": job.attempts, "status_url": url,
                "result_url": url + "/result" if job.status == "done" else None, "result_bytes": job.result_bytes,
                "expires": job.finished + self.settings.job_expiry if job.finished else None}

    # -- cancel and remove -----------------------------------------------------------------------------------
    def delete(self, owner: Optional[str], job_id: str) -> dict[str, Any]:
        """A queued or running job is cancelled (its record stays, status "cancelled", until it expires); a
        finished one is removed. Either way its files go now."""
        job = self.get(owner, job_id)
        if job.status in ACTIVE and self.db.cancel(job_id):
            self.files.remove(job_id)
            return self.describe(self.db.get(job_id))
        self.files.remove(job_id)
        self.db.delete(job_id)
        return {**self.describe(job), "status": "removed"}


def _payload(decoded: dict[str, Any]) -> dict[str, Any]:
    """An .npz body (members robot, kind, options as JSON, torque as JSON, every array an input) -> the JSON
    body's shape; a JSON body is returned as is."""
    if "inputs" in decoded or not any(isinstance(v, np.ndarray) for v in decoded.values()):
        return decoded
    out: dict[str, Any] = {"inputs": {}}
    torque_arrays = {}
    for name, value in decoded.items():
        if name in ("robot", "kind"):
            out[name] = value
        elif name in ("options", "torque"):
            try:
                parsed = json.loads(value) if isinstance(value, str) else value
            except json.JSONDecodeError:
                raise InvalidInput(f"{name}: not a JSON object", name) from None
            if name == "options":
                out["options"] = parsed
            else:
                out["inputs"]["torque"] = parsed
        elif name.startswith(torques.PREFIX):
            torque_arrays[name] = value
        else:
            out["inputs"][name] = value
    if torque_arrays:
        out["inputs"]["torque"] = torques.join(out["inputs"].get("torque", {}), torque_arrays)
    return out
