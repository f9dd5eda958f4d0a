"""Jobs: ``POST /v1/jobs`` (202), ``GET /v1/jobs``, ``GET /v1/jobs/{id}``, ``GET /v1/jobs/{id}/result``,
``DELETE /v1/jobs/{id}`` (the work is :class:`service.jobs.manager.Jobs`'; the jobs run in
:mod:`service.jobs.executor`'s worker processes, never in the request).

What needs no body is checked before a byte of it is read (the media type, the declared size, the key's jobs and
quota: :meth:`~service.jobs.manager.Jobs.admit`). A JSON body (up to ``DYNAMICS_MAX_BODY_BYTES``) is read into
memory, an .npz body (up to ``DYNAMICS_MAX_JOB_INPUT_BYTES``) into a file as it arrives; decoding, checking and
storing it happen in a compute thread, the decoding within the request's time budget (which starts once the body
is in). The result is streamed from its file.
"""

from __future__ import annotations

import contextlib
import json
from typing import Optional

import numpy as np
from fastapi import APIRouter, Depends, Request
from starlette.responses import FileResponse, Response

from .. import schemas
from ..auth import caller
from ..codec import JSON, NPZ, declared_length, encode, read_body, spool_body, wants_npz
from ..compute import Budget
from ..deps import Deps, budget, deps
from ..errors import NotOffered
from ..jobs.files import read_npz
from ..jobs.manager import Jobs
from . import ERRORS, body_doc

router = APIRouter(prefix="/v1")
_JOB_ERRORS = {**ERRORS, **{s: {"model": schemas.ErrorAnswer} for s in (409, 429, 501, 507)}}


def _jobs(request: Request) -> Jobs:
    jobs = getattr(request.app.state, "jobs", None)
    if jobs is None or jobs.executor is None:
        raise NotOffered("jobs: not available on this server (DYNAMICS_JOB_WORKERS=0)")
    return jobs


def _json(doc, status: int = 200, headers: Optional[dict[str, str]] = None) -> Response:
    return Response(json.dumps(doc).encode(), status_code=status, media_type=JSON, headers=headers)


@router.post("/jobs", status_code=202, response_model=schemas.JobStatus, responses=_JOB_ERRORS,
             openapi_extra=body_doc(schemas.JobRequest),
             summary="submit a job (simulate_many, or a dynamics batch of any size); answers at once with its id")
async def submit(request: Request, d: Deps = Depends(deps), owner: Optional[str] = Depends(caller)) -> Response:
    jobs = _jobs(request)
    content_type = request.headers.get("content-type")
    seconds = budget(request).seconds  # (a bad X-Time-Budget is refused now, before the body)
    body = await d.compute.run(jobs.admit, owner, content_type, declared_length(request))
    with contextlib.ExitStack() as stack:
        if body.spooled:
            data = stack.enter_context(jobs.spool())
            await spool_body(request, body.limit, data, setting=body.setting, hint=body.hint)
        else:
            data = await read_body(request, body.limit, setting=body.setting, hint=body.hint)
        time_budget = Budget.starting_now(seconds)  # (the upload's time is the client's, not the budget's)
        status = await d.compute.run_within(time_budget, jobs.submit, owner, data, content_type, time_budget)
    return _json(status, 202, {"Location": status["status_url"]})


@router.get("/jobs", response_model=schemas.JobList, responses=_JOB_ERRORS, summary="this key's jobs")
async def list_jobs(request: Request, d: Deps = Depends(deps), owner: Optional[str] = Depends(caller)) -> Response:
    return _json({"jobs": await d.compute.run(_jobs(request).list, owner)})


@router.get("/jobs/{job_id}", response_model=schemas.JobStatus, responses=_JOB_ERRORS,
            summary="status, progress (done/total), timing and error of a job")
async def status(job_id: str, request: Request, d: Deps = Depends(deps),
                 owner: Optional[str] = Depends(caller)) -> Response:
    return _json(await d.compute.run(_jobs(request).status, owner, job_id))


@router.get("/jobs/{job_id}/result", responses={**_JOB_ERRORS, 200: {"content": {NPZ: {}, JSON: {}}}},
            summary="the result: .npz streamed from disk; JSON when small (DYNAMICS_JOB_JSON_BYTES), finite and not "
                    "asked for as .npz")
async def result(job_id: str, request: Request, d: Deps = Depends(deps),
                 owner: Optional[str] = Depends(caller)) -> Response:
    jobs = _jobs(request)
    job, path = await d.compute.run(jobs.result, owner, job_id)
    accept = request.headers.get("accept")
    if wants_npz(accept) or job.result_bytes > jobs.settings.job_json_bytes:
        return FileResponse(path, media_type=NPZ, filename=f"{job_id}.npz")
    arrays = await d.compute.run(read_npz, path)
    if not all(np.isfinite(a).all() for a in arrays.values() if a.dtype.kind == "f"):  # JSON has no NaN: runs
        return FileResponse(path, media_type=NPZ, filename=f"{job_id}.npz")         # that stopped early are NaN
    for name, a in arrays.items():  # reports, contacts.pairs: JSON held in a 0-d string member
        if a.ndim == 0 and a.dtype.kind == "U":
            arrays[name] = json.loads(str(a))
    return await d.compute.run(encode, arrays, JSON)


@router.delete("/jobs/{job_id}", response_model=schemas.JobStatus, responses=_JOB_ERRORS,
               summary="cancel a queued or running job (status 'cancelled'), or remove a finished one; files go now")
async def delete(job_id: str, request: Request, d: Deps = Depends(deps),
                 owner: Optional[str] = Depends(caller)) -> Response:
    return _json(await d.compute.run(_jobs(request).delete, owner, job_id))
