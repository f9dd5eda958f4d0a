"""Liveness (``/v1/health``: the process answers) and readiness (``/v1/ready``: it takes requests).

Both are open without an API key (probes of an orchestrator carry none) and answer from the event loop at once.
The service has no warm-up any more (the library's C++ core is compiled when it is installed), so the server is
ready once it has started: its routes answer only after the lifespan has opened the robot store. ``/v1/ready``
is kept (it is part of the API, and probes use it); it no longer answers 503.
"""

from __future__ import annotations

from fastapi import APIRouter
from starlette.responses import Response

from .. import schemas
from ..codec import JSON

HEALTH_PATH = "/v1/health"
READY_PATH = "/v1/ready"
OPEN_PATHS = (HEALTH_PATH, READY_PATH)

router = APIRouter()


@router.get(HEALTH_PATH, response_model=schemas.HealthAnswer,
            summary="liveness: 200 when the server answers")
async def health() -> Response:
    return Response(b'{"status":"ok"}', media_type=JSON)


@router.get(READY_PATH, response_model=schemas.ReadyAnswer,
            summary="readiness: 200 once the server has started (its robot store open)")
async def ready() -> Response:
    return Response(b'{"status":"ready"}', media_type=JSON)
