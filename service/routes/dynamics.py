"""The dynamics operations (RNEA, ABA, CRBA, gravity and bias forces, Coriolis matrix, energies):
``POST /v1/robots/{id}/<operation>`` with one state or a batch.

Request bodies are read by :func:`service.codec.read_body` (size limit enforced while reading) and decoded in a
compute thread together with the computation, so that neither parsing megabytes of JSON nor the numbers block
the event loop; a tiny request (one state) whose model is cached runs on the loop (a thread hop would
cost more than the work).
"""

from __future__ import annotations

from typing import Optional

from fastapi import APIRouter, Request
from pydantic import BaseModel
from starlette.responses import Response

from .. import schemas
from ..codec import NPZ, decode, encode, media_type, read_body
from ..compute import INLINE_BYTES, OPERATIONS, Budget, Operation, check_time
from ..auth import caller
from ..deps import Deps, budget
from . import ERRORS, body_doc

router = APIRouter(prefix="/v1")


def _route(op: Operation, schema: type[BaseModel]):
    names = frozenset(schema.model_fields)  # (an .npz body holding other members is refused before any is read)

    async def route(robot_id: str, request: Request) -> Response:
        d: Deps = request.app.state.deps  # (not Depends: it costs ~50 us on the hottest path)
        time_budget = budget(request)
        robot_id = d.catalog.resolve(robot_id, caller(request))
        body = await read_body(request, d.settings.max_body_bytes)
        content_type, accept = request.headers.get("content-type"), request.headers.get("accept")
        if len(body) <= INLINE_BYTES and media_type(content_type) != NPZ:  # (small .npz may unpack to much)
            args = dict(schemas.validate(schema, decode(body, content_type, max_unpacked=0)))
            if d.compute.can_inline(op, robot_id, args):
                return encode(d.compute.dynamics(op, robot_id, args, time_budget, accept), accept)
            return await d.compute.run_within(time_budget, _compute, d, op, robot_id, args, accept, time_budget)
        return await d.compute.run_within(time_budget, _answer, d, op, schema, names, robot_id, body, content_type,
                                          accept, time_budget)

    route.__name__ = op.function
    return route


def _answer(d: Deps, op: Operation, schema: type[BaseModel], names: frozenset[str], robot_id: str, body: bytes,
            content_type: Optional[str], accept: Optional[str], time_budget: Budget) -> Response:
    """In a compute thread: decode (within the budget), compute (within the budget), encode."""
    payload = decode(body, content_type, max_unpacked=8 * d.settings.max_body_bytes, names=names,
                     check=lambda: check_time(time_budget, f"{op.name} (decoding the body)"))
    args = dict(schemas.validate(schema, payload))
    del body
    return _compute(d, op, robot_id, args, accept, time_budget)


def _compute(d: Deps, op: Operation, robot_id: str, args: dict, accept: Optional[str],
             time_budget: Budget) -> Response:
    """In a compute thread: compute (within the budget), encode if time is left."""
    result = d.compute.dynamics(op, robot_id, args, time_budget, accept)
    check_time(time_budget, f"{op.name} (before encoding the answer)")
    return encode(result, accept)


def add_routes(router: APIRouter, operations: dict[str, Operation]) -> None:
    """``POST /v1/robots/{id}/<segment>`` for each operation of ``operations`` (by segment), as its endpoint says."""
    for segment, op in operations.items():
        schema, answer_schema, summary = op.endpoint
        router.add_api_route(f"/robots/{{robot_id}}/{segment}", _route(op, schema),
                             methods=["POST"], response_model=answer_schema, responses=ERRORS,
                             openapi_extra=body_doc(schema), summary=summary)


add_routes(router, OPERATIONS)
#: URL segment -> its Endpoint (request schema, answer schema, summary), read from OPERATIONS
ROUTES = {segment: op.endpoint for segment, op in OPERATIONS.items()}
