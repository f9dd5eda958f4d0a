"""``POST /v1/robots/{id}/simulate``: a trajectory from (q0, v0), computed in a worker process within the budget
(503 only when every worker stays busy until the deadline)."""

from __future__ import annotations

import json
from typing import Any, Optional

from fastapi import APIRouter, Depends, Request
from starlette.responses import Response

from .. import schemas
from ..codec import NPZ, decode, encode, media_type, read_body
from ..compute import INLINE_BYTES, Budget
from ..auth import caller
from ..deps import Deps, budget, deps
from ..errors import InvalidInput
from ..models import locked_key
from ..sim.job import Job
from . import ERRORS, body_doc

router = APIRouter(prefix="/v1")
#: the members an .npz simulate body may hold (one per field; others are refused before any is read)
SIMULATE_FIELDS = frozenset(schemas.SimulateRequest.model_fields)


@router.post("/robots/{robot_id}/simulate", response_model=schemas.TrajectoryAnswer,
             responses={**ERRORS, 501: {"model": schemas.ErrorAnswer}, 503: {"model": schemas.ErrorAnswer}},
             openapi_extra=body_doc(schemas.SimulateRequest),
             summary="simulate from (q0, v0) for a duration under a torque law; runs in a worker process")
async def simulate(robot_id: str, request: Request, d: Deps = Depends(deps),
                   time_budget: Budget = Depends(budget)) -> Response:
    robot_id = d.catalog.resolve(robot_id, caller(request))
    body = await read_body(request, d.settings.max_body_bytes)
    d.compute.require_simulation()
    accept, content_type = request.headers.get("accept"), request.headers.get("content-type")
    if len(body) <= INLINE_BYTES and media_type(content_type) != NPZ:  # small: decoded here (microseconds), and
        req = _request(d, body, content_type)                           # built here too if its model is cached
        if d.compute.models.is_cached(robot_id, locked_key(req.locked)):
            job, scene = d.compute.simulation_job(robot_id, req, accept)
        else:  # (a URDF to parse: milliseconds, off the event loop)
            job, scene = await d.compute.run_within(time_budget, d.compute.simulation_job, robot_id, req, accept)
    else:
        job, scene = await d.compute.run_within(time_budget, _job, d, robot_id, body, content_type, accept)
    del body
    trajectory, seconds = await d.compute.simulate(job, time_budget, accept)
    response = await d.compute.run_within(time_budget, encode, {**trajectory, "scene": scene}, accept)
    # the library call's own time: what the service adds is the rest (benchmarks.service measures it)
    response.headers["Server-Timing"] = f"library;dur={seconds * 1e3:.3f}"
    return response


def _job(d: Deps, robot_id: str, body: bytes, content_type: Optional[str],
         accept: Optional[str]) -> tuple[Job, dict[str, Any]]:
    """In a compute thread: decode the request, then the job and the scene of its answer."""
    return d.compute.simulation_job(robot_id, _request(d, body, content_type), accept)


def _request(d: Deps, body: bytes, content_type: Optional[str]) -> schemas.SimulateRequest:
    """The body -> the validated request."""
    payload = decode(body, content_type, max_unpacked=8 * d.settings.max_body_bytes, names=SIMULATE_FIELDS)
    for name, kind in (("torque", "object"), ("outputs", "list"), ("contact", "object"),
                       ("sensitivities", "list")):  # in .npz these travel as JSON strings
        if isinstance(payload.get(name), str) and payload[name].lstrip()[:1] in ("{", "["):
            try:
                payload[name] = json.loads(payload[name])
            except json.JSONDecodeError:
                raise InvalidInput(f"{name}: not a JSON {kind}", name) from None
    return schemas.validate(schemas.SimulateRequest, payload)
