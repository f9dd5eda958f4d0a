"""What the job routes call: submit (check, store the inputs, queue), status, result, cancel and remove.

Everything here runs in a compute thread (file and database writes), never on the event loop, and never
waits on a job. The limits (``DYNAMICS_MAX_JOB_INPUT_BYTES``, ``_MAX_JOB_RESULT_BYTES``, ``_MAX_JOBS_PER_KEY``,
``_JOB_QUOTA_BYTES``, ``_JOB_EXPIRY``) are checked at submission, so that a job refused is refused at once
with the reason, not after hours in the queue; those that need no body (:meth:`Jobs.admit`: the media type, the
declared size, the key's jobs and quota) before a byte of it is read. A job's body costs about the arrays it
holds: a JSON body is at most the normal request limit (``DYNAMICS_MAX_BODY_BYTES``: decoded, JSON numbers take
~15 times their text), an ``.npz`` body is written to a file as it arrives (:meth:`Jobs.spool`) and its members
read from there into their arrays. A job belongs to the key that made it: any other key gets the same 404 as for
a job that does not exist.
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
import time
import typing
import uuid
from pathlib import Path
from typing import Any, BinaryIO, Callable, Iterator, NamedTuple, Optional, Union

import numpy as np
from pydantic import TypeAdapter, ValidationError

from .. import errors, schemas
from .. import torque as torques
from ..codec import JSON, NPZ, decode, media_type, to_array, too_large
from ..compute import Budget, check_time
from ..errors import InvalidInput, NotFound, Problem, TooLarge, UnsupportedMediaType, figure, storage_full
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


def _torque_members() -> set[str]:
    """``torque.<field>`` for every field of every torque type, and ``torque.reference.<field>``: where an .npz
    body carries a torque's arrays (service.torque.join puts them back)."""
    names = {f"{torques.PREFIX}reference.{f}" for f in schemas.TaskReferenceSpec.model_fields}
    for spec in typing.get_args(typing.get_args(schemas.TorqueSpec)[0]):
        names |= {torques.PREFIX + f for f in spec.model_fields}
    return names


#: the members an .npz job body may hold (each once): robot, kind, options and torque (JSON strings), the
#: inputs of every kind, and a torque's arrays. An archive of other or more members is refused unread.
JOB_MEMBERS = frozenset({"robot", "kind", "options", "torque", *(n for k in KINDS.values() for n in k.states),
                         *_torque_members()})
#: what a JSON job body over the normal request limit is told
JSON_JOB_HINT = ("a job's JSON body is at most the normal request limit (decoded, JSON numbers take ~15 times their "
                 f"text); send larger inputs as .npz (Content-Type: {NPZ}; the Python client's submit does), up to "
                 "DYNAMICS_MAX_JOB_INPUT_BYTES")


class Body(NamedTuple):
    """How a job's body is received: to a file as it arrives (.npz) or in memory (JSON), and its limit."""
    spooled: bool
    limit: int
    setting: str
    hint: str


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
    def body(self, content_type: Optional[str], size: Optional[int]) -> Body:
        """How a body of this media type is received, and its limit; 415 for another type, 413 for a ``size``
        (declared, or once known) over the limit."""
        kind = media_type(content_type) if content_type is not None else JSON
        s = self.settings
        if kind == NPZ:
            body = Body(True, s.max_job_input_bytes, "DYNAMICS_MAX_JOB_INPUT_BYTES", "split the job")
        elif kind == JSON or kind.endswith("+json"):
            body = Body(False, min(s.max_body_bytes, s.max_job_input_bytes), "DYNAMICS_MAX_BODY_BYTES", JSON_JOB_HINT)
        else:
            raise UnsupportedMediaType(f"Content-Type: {kind or content_type!r:.64} is not accepted here; send {JSON} "
                                       f"or {NPZ}", "Content-Type")
        if size is not None and size > body.limit:
            raise too_large(body.limit, body.setting, body.hint)
        return body

    def admit(self, owner: Optional[str], content_type: Optional[str], declared: Optional[int]) -> Body:
        """The refusals that need no body, before a byte of it is read: its media type and declared size (415,
        413), the key's jobs queued or running (429) and its quota (507). How to receive it."""
        body = self.body(content_type, declared)
        owner = owner or ""
        self._check_active(owner)
        used = self.db.bytes_used(owner)
        if used + (declared or 0) > self.settings.job_quota_bytes:
            raise self._over_quota(used)
        return body

    @contextlib.contextmanager
    def spool(self) -> Iterator[BinaryIO]:
        """A file in the job store for a body being received: anonymous (O_TMPFILE where the system has it), so
        that it goes when closed, or with the process. A full disk is a 507."""
        try:
            with tempfile.TemporaryFile(dir=self.files.incoming) as f:
                yield f
        except OSError as e:
            raise storage_full(e, f"the job store {self.files.root}") or e

    def submit(self, owner: Optional[str], body: Union[bytes, BinaryIO], content_type: Optional[str],
               budget: Optional[Budget] = None) -> dict[str, Any]:
        """Check a job request, store its inputs durably and queue it; its status (202). ``body``: bytes, or the
        file :meth:`spool` received it in; ``budget``: the request's, for the decoding."""
        owner = owner or ""
        s = self.settings
        size = len(body) if isinstance(body, bytes) else body.seek(0, os.SEEK_END)
        if not isinstance(body, bytes):
            body.seek(0)
        self.body(content_type, size)
        self._check_active(owner)  # (again: it may have changed while the body arrived)
        check = None if budget is None else \
            (lambda: check_time(budget, "decoding the job's inputs", "send them as .npz, or split the job"))
        payload = decode(body, content_type, max_unpacked=4 * s.max_job_input_bytes, names=JOB_MEMBERS,
                         check=check)
        req = schemas.validate(schemas.JobRequest, _payload(payload))
        del payload
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
        if used + estimate + size > s.job_quota_bytes:
            raise self._over_quota(used)
        job_id = uuid.uuid4().hex
        try:  # the inputs first (a queued job always has them); on any failure, no file is left behind
            nbytes = write_npz(self.files.inputs(job_id), arrays)
            created = self.db.create(job_id, owner, req.robot, req.kind, spec, total, nbytes,
                                     max_active=s.max_jobs_per_key)
        except Exception as e:
            self.files.remove(job_id)
            raise storage_full(e, f"the job store {self.files.root}") or e
        if not created:  # another submission of this key took the last place meanwhile
            self.files.remove(job_id)
            raise self._too_many()
        if self.executor is not None:
            self.executor.notify()
        return self.describe(self.db.get(job_id))

    def _check_active(self, owner: str) -> None:
        if self.db.active_count(owner) >= self.settings.max_jobs_per_key:
            raise self._too_many()

    def _too_many(self) -> "TooManyJobs":
        return TooManyJobs(f"jobs: this key has {self.settings.max_jobs_per_key} jobs queued or running, the limit "
                           f"(DYNAMICS_MAX_JOBS_PER_KEY); wait for one to finish or cancel one",
                           headers={"Retry-After": "10"})

    def _over_quota(self, used: int) -> "QuotaExceeded":
        return QuotaExceeded(f"jobs: this key's job inputs and results hold {used} bytes; this job's would pass the "
                             f"quota of {self.settings.job_quota_bytes} (DYNAMICS_JOB_QUOTA_BYTES); delete finished "
                             f"jobs (DELETE /v1/jobs/{{id}})")

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
                req.inputs[name] = None  # (the decoded value, when it was not float64 already, is freed now)
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
        for name, x in arrays.items():  # the synchronous routes refuse these too (the library's check): a 422 now,
            where = first_not_finite(x)  # not a job that fails once it runs
            if where is not None:
                raise InvalidInput(f"inputs.{name}: contains non-finite values (nan or inf){where}; a job's inputs "
                                   f"are checked when it is submitted", f"inputs.{name}")
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


def first_not_finite(x: np.ndarray, rows: int = 1 << 16) -> Optional[str]:
    """None when ``x`` holds no NaN or infinity, else where the first is (" (row 12)" of a batch, "" for one
    row). A batch is read in blocks of ``rows`` rows, so that the check takes the memory of a block only."""
    if x.dtype.kind not in "fc":
        return None
    if x.ndim < 2:
        return None if np.isfinite(x).all() else ""
    for lo in range(0, x.shape[0], rows):
        block = x[lo:lo + rows]
        bad = ~np.isfinite(block.reshape(block.shape[0], -1)).all(axis=1)
        if bad.any():
            return f" (row {lo + int(np.argmax(bad))})"
    return None


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
