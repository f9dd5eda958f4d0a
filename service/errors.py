"""The one error type routes raise, and how every failure becomes a JSON answer.

Every answer that is not a success has the body ``{"detail": "<field>: <what was expected>", "code": ..., "field":
...}``: ``detail`` is a sentence a person can act on, ``code`` a stable machine name, ``field`` the request field
at fault (or null). Bad input is always a 4xx; only a bug in the service itself can give a 500.
"""

from __future__ import annotations

import json
import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.responses import Response

log = logging.getLogger("service")


class ApiError(Exception):
    """A failure with its HTTP status; ``detail`` should start with the field name when there is one."""

    def __init__(self, status: int, detail: str, *, code: str = "invalid_input", field: str | None = None,
                 headers: dict[str, str] | None = None):
        super().__init__(detail)
        self.status = status
        self.detail = detail
        self.code = code
        self.field = field
        self.headers = headers or {}


def bad_input(detail: str, field: str | None = None) -> ApiError:
    return ApiError(422, detail, code="invalid_input", field=field)


def field_of(message: str) -> str | None:
    """'q: expected shape ...' -> 'q' (the library's messages start with the argument name)."""
    head, sep, _ = message.partition(":")
    if sep and head and len(head) <= 40 and " " not in head.strip():
        return head.strip()
    return None


def error_response(status: int, detail: str, code: str, field: str | None = None,
                   headers: dict[str, str] | None = None) -> Response:
    body = json.dumps({"detail": detail, "code": code, "field": field}).encode()
    return Response(body, status_code=status, media_type="application/json", headers=headers)


_STATUS_CODES = {400: "bad_request", 401: "unauthorized", 403: "forbidden", 404: "not_found",
                 405: "method_not_allowed", 406: "not_acceptable", 409: "conflict", 413: "too_large",
                 415: "unsupported_media_type", 422: "invalid_input", 504: "time_budget_exceeded"}


def install_handlers(app: FastAPI) -> None:
    @app.exception_handler(ApiError)
    async def _api_error(request: Request, exc: ApiError) -> Response:
        return error_response(exc.status, exc.detail, exc.code, exc.field, exc.headers)

    @app.exception_handler(StarletteHTTPException)
    async def _http_error(request: Request, exc: StarletteHTTPException) -> Response:
        code = _STATUS_CODES.get(exc.status_code, "error")
        return error_response(exc.status_code, str(exc.detail), code, None, getattr(exc, "headers", None))

    @app.exception_handler(RequestValidationError)
    async def _validation_error(request: Request, exc: RequestValidationError) -> Response:
        first = exc.errors()[0] if exc.errors() else {"loc": (), "msg": "invalid request"}
        loc = [str(p) for p in first.get("loc", ()) if p not in ("body", "query", "path")]
        name = ".".join(loc) or None
        return error_response(422, f"{name or 'request'}: {first.get('msg')}", "invalid_input", name)

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, exc: Exception) -> Response:  # pragma: no cover - a bug
        log.exception("unexpected error on %s %s", request.method, request.url.path)
        return error_response(500, f"internal error: {type(exc).__name__}", "internal_error")
