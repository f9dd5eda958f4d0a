"""The service's own errors, and the one place where they and the library's become HTTP answers.

The modules of the service raise a :class:`Problem` subclass named for what went wrong (:class:`NotFound`,
:class:`InvalidInput`, ...) and never an HTTP status; :data:`STATUS` below gives each its status. The library's
input errors (``dynamics.DynamicsError``: ``InputError``, ``URDFError``; their message starts with the argument's
name, "q: expected shape (2,) or (B, 2), got (1,)") are answered 422 naming that argument.

Every answer that is not a success has the body ``{"detail": "<field>: <what was expected>", "code": ...,
"field": ...}``: ``detail`` is a sentence a person can act on, ``code`` a stable machine name, ``field`` the
request field at fault (or null). Bad input is always a 4xx; only a bug in the service itself gives a 500.
"""

from __future__ import annotations

import errno
import json
import logging
import re
import sys
import uuid
from typing import Any, Optional

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from starlette.background import BackgroundTask
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.requests import ClientDisconnect
from starlette.responses import Response

from . import memory

log = logging.getLogger("service")


class Problem(Exception):
    """A request the service cannot answer as asked; ``detail`` starts with ``field`` when there is one, ``code``
    (a stable machine name) defaults to the class's in :data:`STATUS`."""

    def __init__(self, detail: str, field: str | None = None, *, code: str | None = None,
                 headers: dict[str, str] | None = None):
        super().__init__(detail)
        self.detail = detail
        self.field = field
        self.code = code
        self.headers = headers or {}


class BadRequest(Problem):
    """The request cannot even be read (a malformed header)."""


class Unauthorized(Problem):
    """No valid API key."""


class Forbidden(Problem):
    """The key may not do this (delete a bundled robot, or another key's)."""


class NotFound(Problem):
    """No such robot."""


class Conflict(Problem):
    """The name is taken by another robot of this key, or names several robots."""


class RequestTimeout(Problem):
    """The client took longer than DYNAMICS_READ_TIMEOUT to send its body."""


class TooLarge(Problem):
    """A body, an unpacked archive or a URDF over its limit."""


class UnsupportedMediaType(Problem):
    """A Content-Type the route does not read."""


class InvalidInput(Problem):
    """The content is wrong: the detail names the field and says what was expected."""


class Failed(Problem):
    """Not the caller's fault: a simulation worker crashed, or the library failed unexpectedly."""


class NotOffered(Problem):
    """This server does not offer the operation (simulation turned off)."""


class Unavailable(Problem):
    """Not now: every simulation worker stayed busy (or was still starting) until the deadline; ``Retry-After``
    says when to ask again."""


class BudgetExceeded(Problem):
    """The work ran past the request's time budget and was stopped."""

    def __init__(self, what: str, budget: float, hint: str):
        super().__init__(f"time budget: {what} was stopped after {budget:g} s (DYNAMICS_TIME_BUDGET or "
                         f"X-Time-Budget); {hint}")


class StorageFull(Problem):
    """The disk (or the quota) holding the robot store or the job files is full: 507 Insufficient Storage."""


#: the errnos of a full disk or quota
FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


def storage_full(error: BaseException, storage: str) -> Optional[StorageFull]:
    """A :class:`StorageFull` naming ``storage`` ("the robot store /srv/store") for an OSError of a full disk
    (or SQLite's "database or disk is full"), None for any other error."""
    full = (isinstance(error, OSError) and error.errno in FULL) or "disk is full" in str(error)
    if not full:
        return None
    why = error.strerror if isinstance(error, OSError) and error.strerror else str(error)
    return StorageFull(f"storage: {storage} is full ({why}); free space there, or delete robots or finished jobs",
                       "storage")


#: each problem's HTTP status and default code
STATUS: dict[type[Problem], tuple[int, str]] = {
    BadRequest: (400, "bad_request"), Unauthorized: (401, "unauthorized"), Forbidden: (403, "forbidden"),
    NotFound: (404, "not_found"), RequestTimeout: (408, "request_timeout"), Conflict: (409, "conflict"),
    TooLarge: (413, "too_large"), UnsupportedMediaType: (415, "unsupported_media_type"),
    InvalidInput: (422, "invalid_input"), Failed: (500, "internal_error"), NotOffered: (501, "not_implemented"),
    Unavailable: (503, "busy"), BudgetExceeded: (504, "time_budget_exceeded"),
    StorageFull: (507, "insufficient_storage"),
}

# Starlette's own refusals (unknown path, wrong method) keep their status; this names them.
_CODES = {400: "bad_request", 401: "unauthorized", 403: "forbidden", 404: "not_found", 405: "method_not_allowed",
          406: "not_acceptable", 409: "conflict", 413: "too_large", 415: "unsupported_media_type",
          422: "invalid_input", 504: "time_budget_exceeded"}


#: longest ``detail`` sent: a library message quoting a huge name or document is cut, never echoed whole
MAX_DETAIL = 1000
#: longest caller-given text (an id, a name) quoted in a detail
MAX_ECHO = 64


def echo(text: str) -> str:
    """``repr(text)`` for a message, cut to :data:`MAX_ECHO` characters: a 10,000-character id is not echoed."""
    return repr(text) if len(text) <= MAX_ECHO else repr(text[:MAX_ECHO]) + f"... ({len(text)} characters)"


def figure(n: int | float) -> str:
    """A count for a message: as is up to 15 digits, else in scientific notation (a job of 1e300 s is "about
    8.00e+303 bytes", not 304 digits)."""
    digits = str(int(n))
    return digits if len(digits) <= 15 else f"{digits[0]}.{digits[1:3]}e+{len(digits) - 1}"


def bounded(detail: str) -> str:
    return detail if len(detail) <= MAX_DETAIL else detail[:MAX_DETAIL] + f"... ({len(detail)} characters)"


def field_of(message: str) -> str | None:
    """'q: expected shape ...' -> 'q' (the library's messages start with the argument name)."""
    head, sep, _ = message.partition(":")
    if sep and head and len(head) <= 40 and " " not in head.strip():
        return head.strip()
    return None


def error_response(status: int, detail: str, code: str, field: str | None = None,
                   headers: dict[str, str] | None = None) -> Response:
    body = json.dumps({"detail": bounded(detail), "code": code, "field": field and field[:MAX_DETAIL]}).encode()
    return Response(body, status_code=status, media_type="application/json", headers=headers)


def problem_response(problem: Problem) -> Response:
    status, code = STATUS[type(problem)]
    response = error_response(status, problem.detail, problem.code or code, problem.field, problem.headers)
    if isinstance(problem, BudgetExceeded):  # the stopped work's memory goes back to the system once answered
        response.background = BackgroundTask(memory.release)
    return response


def is_library_input_error(exc: BaseException) -> bool:
    """True for ``dynamics.DynamicsError``. The library is looked up, not imported: the server imports it in the
    background (see :mod:`service.deps`), and an error raised before that cannot be the library's."""
    dynamics = sys.modules.get("dynamics")
    return dynamics is not None and isinstance(exc, dynamics.DynamicsError)


def install(app: FastAPI) -> None:
    """Register the mapping on ``app``: problems, the library's input errors, Starlette's and FastAPI's own."""

    async def problem(request: Request, exc: Problem) -> Response:
        return problem_response(exc)

    async def value_error(request: Request, exc: ValueError) -> Response:
        if is_library_input_error(exc):
            return problem_response(InvalidInput(str(exc), field_of(str(exc))))
        return await unexpected(request, exc)  # a ValueError of the service's own is a bug

    async def http_error(request: Request, exc: StarletteHTTPException) -> Response:
        return error_response(exc.status_code, str(exc.detail), _CODES.get(exc.status_code, "error"), None,
                              getattr(exc, "headers", None))

    async def validation_error(request: Request, exc: RequestValidationError) -> Response:
        first: dict[str, Any] = exc.errors()[0] if exc.errors() else {"loc": (), "msg": "invalid request"}
        name = ".".join(str(p) for p in first.get("loc", ()) if p not in ("body", "query", "path")) or None
        return problem_response(InvalidInput(f"{name or 'request'}: {first.get('msg')}", name))

    async def unexpected(request: Request, exc: Exception) -> Response:  # pragma: no cover - a bug
        return internal_error(request.scope, exc)

    app.add_exception_handler(Problem, problem)
    app.add_exception_handler(ValueError, value_error)
    app.add_exception_handler(StarletteHTTPException, http_error)
    app.add_exception_handler(RequestValidationError, validation_error)
    # (no handler for Exception: RequestIds, outside every route, answers those once; Starlette's handler for
    # Exception would answer and then re-raise, and uvicorn would log the traceback a second time)


REQUEST_ID = "dynamics.request_id"
_GIVEN_ID = re.compile(rb"^[A-Za-z0-9._-]{1,64}$")


def internal_error(scope: dict, exc: BaseException) -> Response:
    """A bug: logged once with its traceback and the request id; the caller gets a 500 quoting that id."""
    rid = scope.get(REQUEST_ID, "-")
    log.error("unexpected error on %s %s (request %s)", scope.get("method"), scope.get("path"), rid,
              exc_info=(type(exc), exc, exc.__traceback__))
    return error_response(500, f"internal error ({type(exc).__name__}); request id {rid}: this is a bug, "
                               f"please report it with the id", "internal_error", None, {"X-Request-ID": rid})


class RequestIds:
    """Pure ASGI middleware, outermost but for the headers every answer carries (service.protocol.SecurityHeaders,
    which raises nothing): every answer carries ``X-Request-ID`` (the caller's if it sent a short
    plain one, else a fresh one), and an exception escaping a route is answered here, 500 quoting that id, and
    logged once. A client that hangs up mid-body (:class:`ClientDisconnect`) is not an error: nothing is logged."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        given = next((v for k, v in scope["headers"] if k == b"x-request-id"), b"")
        rid = given.decode() if _GIVEN_ID.match(given) else uuid.uuid4().hex[:16]
        scope[REQUEST_ID] = rid
        started = False

        async def send_with_id(message):
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
                headers = [(k, v) for k, v in message.get("headers", []) if k.lower() != b"x-request-id"]
                message = {**message, "headers": headers + [(b"x-request-id", rid.encode())]}
            await send(message)

        try:
            await self.app(scope, receive, send_with_id)
        except ClientDisconnect:
            log.debug("request %s: the client disconnected before sending its whole body", rid)
        except Exception as exc:
            response = internal_error(scope, exc)
            if not started:
                await response(scope, receive, send)
