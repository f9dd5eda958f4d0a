"""Jobs: ``POST /v1/jobs`` (202), ``GET /v1/jobs``, ``GET /v1/jobs/{id}``, ``GET /v1/jobs/{id}/result``,
``DELETE /v1/jobs/{id}`` (the work is :class:`service.jobs.manager.Jobs`'; the jobs run in
:mod:`service.jobs.executor`'s worker processes, never in the request).

The body (JSON or .npz, up to ``DYNAMICS_MAX_JOB_INPUT_BYTES``) is read with its limit enforced while reading;
checking and storing it happen in a compute thread. The result is streamed from its file.
"""

from __future__ import annotations

import json
from typing import Optional

import numpy as np
from fastapi import APIRouter, Depends, Request
from starlette.responses import FileResponse, Response

from .. import schemas
from ..auth import caller
from ..codec import JSON, NPZ, encode, read_body, wants_npz
from ..deps import Deps, deps
from ..errors import NotOffered, TooLarge
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
    limit = jobs.settings.max_job_input_bytes
    try:
        body = await read_body(request, limit)
    except TooLarge:
        raise TooLarge(f"body: larger than the jobs' limit of {limit} bytes (DYNAMICS_MAX_JOB_INPUT_BYTES); split "
                       f"the job", "body", headers={"Connection": "close"}) from None
    status = await d.compute.run(jobs.submit, owner, body, request.headers.get("content-type"))
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
