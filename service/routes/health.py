"""Liveness (``/v1/health``: the process answers) and readiness (``/v1/ready``: the warm-up is over).

Both are open without an API key (probes of an orchestrator carry none) and answer from the event loop at once,
during the warm-up too.
"""

from __future__ import annotations

import json

from fastapi import APIRouter, Depends
from starlette.responses import Response

from .. import schemas
from ..codec import JSON
from ..deps import Deps, deps
from ..errors import Unavailable

HEALTH_PATH = "/v1/health"
READY_PATH = "/v1/ready"
OPEN_PATHS = (HEALTH_PATH, READY_PATH)

router = APIRouter()


@router.get(HEALTH_PATH, response_model=schemas.HealthAnswer,
            summary="liveness: 200 when the server answers (at once, also while it warms up)")
async def health() -> Response:
    return Response(b'{"status":"ok"}', media_type=JSON)


@router.get(READY_PATH, response_model=schemas.ReadyAnswer, responses={503: {"model": schemas.ErrorAnswer}},
            summary="readiness: 200 once the warm-up is over (status 'degraded' and its failures if a stage failed); "
                    "503 before, saying how long it takes")
async def ready(d: Deps = Depends(deps)) -> Response:
    warmup = d.warmup
    if not warmup.done:
        raise Unavailable(f"ready: {warmup.status()}", code="starting",
                          headers={"Retry-After": str(warmup.retry_after())})
    # A stage that failed leaves the service up (what compiled answers) but says so: "degraded", and what failed
    body = {"status": "degraded" if warmup.failures else "ready", "warmup_seconds": round(warmup.seconds, 3),
            "failures": warmup.failures}
    return Response(json.dumps(body).encode(), media_type=JSON)
