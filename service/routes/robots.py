"""Robots: upload a URDF, list, describe, delete (the work is :class:`service.catalog.Catalog`'s)."""

from __future__ import annotations

import json
from typing import Literal, Optional

from fastapi import APIRouter, Depends, Query, Request
from starlette.responses import Response

from .. import schemas
from ..auth import caller
from ..codec import JSON, XML_TYPES, decode, media_type, read_body
from ..deps import Deps, deps
from ..errors import InvalidInput, UnsupportedMediaType
from . import ERRORS

router = APIRouter(prefix="/v1")

_EXAMPLE = schemas.UploadRequest.model_config["json_schema_extra"]["examples"][0]
_UPLOAD_BODY = {"requestBody": {"required": True, "content": {
    "application/xml": {"schema": {"type": "string", "description": "the URDF document: a <robot> element; other "
                                   "XML, DTDs and entities are a 422 naming urdf"}, "example": _EXAMPLE["urdf"]},
    JSON: {"schema": {"$ref": "#/components/schemas/UploadRequest"}, "example": _EXAMPLE}}}}


@router.post("/robots", status_code=201, response_model=schemas.UploadAnswer,
             responses={**ERRORS, 200: {"model": schemas.UploadAnswer, "description": "already stored: the same "
                                        "robot (same key, URDF, name and options)"},
                        409: {"model": schemas.ErrorAnswer}},
             openapi_extra=_UPLOAD_BODY,
             summary="upload a URDF; 201 with its id, or 200 with the existing id when it is already stored")
async def upload(request: Request, name: Optional[str] = Query(None, max_length=128),
                 floating_base: bool = Query(False),
                 mimic: Optional[Literal["coupling", "independent"]] = Query(None), d: Deps = Depends(deps),
                 owner: Optional[str] = Depends(caller)) -> Response:
    body = await read_body(request, d.settings.max_body_bytes)
    header = request.headers.get("content-type")
    kind = media_type(header)
    constraints = None
    if kind in XML_TYPES:
        urdf = body
    elif kind == JSON or header is None:  # (no Content-Type is JSON; one naming no type, ";;;;", is refused)
        req = schemas.validate(schemas.UploadRequest, decode(body, JSON, max_unpacked=0))
        urdf, name, floating_base = _utf8(req.urdf), req.name if req.name is not None else name, req.floating_base
        constraints, mimic = req.constraints, req.mimic or mimic
    else:
        raise UnsupportedMediaType(f"Content-Type: {kind or header!r:.64} is not accepted; send the URDF as application/xml, or "
                                   f"JSON {{\"urdf\": ...}}", "Content-Type")
    info, created = await d.compute.run(d.catalog.store_upload, urdf, name, floating_base, owner, constraints, mimic)
    return Response(json.dumps(info).encode(), status_code=201 if created else 200, media_type=JSON,
                    headers={"Location": f"/v1/robots/{info['id']}"})


def _utf8(text: str) -> bytes:
    """A JSON string -> UTF-8; JSON can carry a lone surrogate (``"\\ud800"``), which no UTF-8 document holds."""
    try:
        return text.encode("utf-8")
    except UnicodeEncodeError as e:
        raise InvalidInput(f"urdf: not valid Unicode text (a lone surrogate at character {e.start})", "urdf") \
            from None


@router.get("/robots", response_model=schemas.RobotList, responses=ERRORS,
            summary="the robots this key may use: the bundled ones and its own")
async def robots(d: Deps = Depends(deps), owner: Optional[str] = Depends(caller)) -> Response:
    listing = await d.compute.run(d.catalog.list_robots, owner)
    return Response(json.dumps({"robots": listing}).encode(), media_type=JSON)


@router.get("/robots/{robot_id}", response_model=schemas.RobotInfo, responses=ERRORS,
            summary="joints (types, limits, damping) and bodies of one robot")
async def robot(robot_id: str, d: Deps = Depends(deps), owner: Optional[str] = Depends(caller)) -> Response:
    rid = d.catalog.resolve(robot_id, owner)
    return Response(json.dumps(await d.compute.run(d.catalog.describe, rid)).encode(), media_type=JSON)


@router.get("/robots/{robot_id}/inspect", response_model=schemas.RobotInspection, responses=ERRORS,
            summary="the description and what the inspector (/inspect) draws: per-body inertia checks and boxes, "
                    "collision geometry")
async def inspect(robot_id: str, d: Deps = Depends(deps), owner: Optional[str] = Depends(caller)) -> Response:
    rid = d.catalog.resolve(robot_id, owner)
    return Response(json.dumps(await d.compute.run(d.catalog.inspect, rid)).encode(), media_type=JSON)


@router.delete("/robots/{robot_id}", status_code=204, responses={**ERRORS, 403: {"model": schemas.ErrorAnswer}},
               summary="delete an uploaded robot (with the key that uploaded it); bundled robots stay")
async def delete(robot_id: str, d: Deps = Depends(deps), owner: Optional[str] = Depends(caller)) -> Response:
    await d.compute.run(d.catalog.delete, d.catalog.resolve(robot_id, owner), owner)
    return Response(status_code=204)
