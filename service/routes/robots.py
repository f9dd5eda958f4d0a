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
from ..errors import UnsupportedMediaType
from . import ERRORS

router = APIRouter(prefix="/v1")

_EXAMPLE = schemas.UploadRequest.model_config["json_schema_extra"]["examples"][0]
_UPLOAD_BODY = {"requestBody": {"required": True, "content": {
    "application/xml": {"schema": {"type": "string", "description": "the URDF document"}, "example": _EXAMPLE["urdf"]},
    JSON: {"schema": {"$ref": "#/components/schemas/UploadRequest"}, "example": _EXAMPLE}}}}


@router.post("/robots", status_code=201, response_model=schemas.UploadAnswer, responses=ERRORS,
             openapi_extra=_UPLOAD_BODY,
             summary="upload a URDF; the id derives from content and options (same upload, same id)")
async def upload(request: Request, name: Optional[str] = Query(None, max_length=128),
                 floating_base: bool = Query(False),
                 mimic: Optional[Literal["coupling", "independent"]] = Query(None), d: Deps = Depends(deps),
                 owner: Optional[str] = Depends(caller)) -> Response:
    body = await read_body(request, d.settings.max_body_bytes)
    kind = media_type(request.headers.get("content-type"))
    constraints = None
    if kind in XML_TYPES:
        urdf = body
    elif kind == JSON or not kind:
        req = schemas.validate(schemas.UploadRequest, decode(body, JSON, max_unpacked=0))
        urdf, name, floating_base = req.urdf.encode("utf-8"), req.name or name, req.floating_base
        constraints, mimic = req.constraints, req.mimic or mimic
    else:
        raise UnsupportedMediaType(f"Content-Type: {kind!r} is not accepted; send the URDF as application/xml, or "
                                   f"JSON {{\"urdf\": ...}}", "Content-Type")
    info = await d.compute.run(d.catalog.upload, urdf, name, floating_base, owner, constraints, mimic)
    return Response(json.dumps(info).encode(), status_code=201, media_type=JSON,
                    headers={"Location": f"/v1/robots/{info['id']}"})


@router.get("/robots", response_model=schemas.RobotList, responses=ERRORS, summary="every robot")
async def robots(d: Deps = Depends(deps)) -> Response:
    return Response(json.dumps({"robots": await d.compute.run(d.catalog.list_robots)}).encode(), media_type=JSON)


@router.get("/robots/{robot_id}", response_model=schemas.RobotInfo, responses=ERRORS,
            summary="joints (types, limits, damping) and bodies of one robot")
async def robot(robot_id: str, d: Deps = Depends(deps)) -> Response:
    return Response(json.dumps(await d.compute.run(d.catalog.describe, robot_id)).encode(), media_type=JSON)


@router.delete("/robots/{robot_id}", status_code=204, responses={**ERRORS, 403: {"model": schemas.ErrorAnswer}},
               summary="delete an uploaded robot (with the key that uploaded it); bundled robots stay")
async def delete(robot_id: str, d: Deps = Depends(deps), owner: Optional[str] = Depends(caller)) -> Response:
    await d.compute.run(d.catalog.delete, robot_id, owner)
    return Response(status_code=204)
