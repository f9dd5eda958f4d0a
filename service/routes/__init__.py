"""The HTTP routes, one module per resource: thin (parse, call, encode), no numeric code.

:mod:`.health` (liveness and readiness), :mod:`.robots` (upload, list, describe, delete), :mod:`.dynamics` (the
five dynamics operations) and :mod:`.simulate`. What they share for the OpenAPI document is here.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel

from .. import schemas
from ..codec import JSON, NPZ

#: the error answers every route documents
ERRORS: dict[int | str, dict[str, Any]] = {status: {"model": schemas.ErrorAnswer}
                                           for status in (401, 404, 413, 415, 422, 504)}


def body_doc(schema: type[BaseModel], npz: bool = True) -> dict[str, Any]:
    """The OpenAPI request body of a route that reads its body itself: the schema in JSON, or an .npz archive."""
    ref = {"$ref": f"#/components/schemas/{schema.__name__}"}
    content: dict[str, Any] = {JSON: {"schema": ref}}
    examples = (schema.model_config.get("json_schema_extra") or {}).get("examples")
    if examples:  # at the media type too: what Swagger UI fills the "Try it out" body with
        content[JSON]["example"] = examples[0]
    if npz:
        content[NPZ] = {"schema": {"type": "string", "format": "binary",
                                   "description": "numpy .npz archive, one member per field (no pickles)"}}
    return {"requestBody": {"required": True, "content": content}}
