"""HTTP details: a deadline on request headers (:class:`HeaderTimeoutProtocol`), OPTIONS (:class:`Options`), HEAD
(:class:`Head`) and the headers every answer carries (:class:`SecurityHeaders`).

uvicorn's h11 protocol gets a deadline on request headers, so that half-sent requests do not pile up.

uvicorn closes idle keep-alive connections, but a client that sends half its headers and then nothing is kept
forever (its data cancels the keep-alive timer); 1,000 of those held 1,000 sockets. Here a connection whose
request headers are not complete ``DYNAMICS_READ_TIMEOUT`` seconds after it opened (or after its previous
answer) is closed. Bodies have their own timeout, per piece, in :func:`service.codec.read_body`.
"""

from __future__ import annotations

import asyncio
import os

import h11
from starlette.responses import Response
from starlette.routing import Match
from uvicorn.protocols.http.h11_impl import H11Protocol

from .errors import error_response


class HeaderTimeoutProtocol(H11Protocol):
    header_timeout = float(os.environ.get("DYNAMICS_READ_TIMEOUT", "30"))

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._header_timer: asyncio.TimerHandle | None = None
        self._arm()

    def _arm(self) -> None:
        if self._header_timer is not None:
            self._header_timer.cancel()
        self._header_timer = self.loop.call_later(self.header_timeout, self._headers_overdue)

    def _headers_overdue(self) -> None:
        waiting = self.cycle is None or self.cycle.response_complete
        if waiting and self.conn.their_state in (h11.IDLE, h11.DONE) and not self.transport.is_closing():
            self.transport.close()

    def on_response_complete(self) -> None:
        super().on_response_complete()
        self._arm()

    def handle_websocket_upgrade(self, event: h11.Request) -> None:
        # the connection is the WebSocket protocol's from now on (/v1/sessions, with its own idle timeout): a
        # timer left armed would keep this object, and the request it read, alive for DYNAMICS_READ_TIMEOUT (a
        # flood of 6,000 refused sessions held 37 MB for 30 s)
        if self._header_timer is not None:
            self._header_timer.cancel()
            self._header_timer = None
        super().handle_websocket_upgrade(event)

    def connection_lost(self, exc: Exception | None) -> None:
        if getattr(self, "_header_timer", None) is not None:
            self._header_timer.cancel()
        super().connection_lost(exc)


class Options:
    """Pure ASGI middleware: ``OPTIONS <path>`` answers 204 with ``Allow`` listing every method the routes offer
    on that path (Starlette would answer 405 naming only the first matching route's methods), 404 if none."""

    def __init__(self, app, routes):
        self.app = app
        self.routes = routes

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or scope["method"] != "OPTIONS":
            return await self.app(scope, receive, send)
        methods: set[str] = set()
        for route in _leaves(self.routes):
            match, _ = route.matches({**scope, "method": "GET"})
            if match != Match.NONE and getattr(route, "methods", None):
                methods |= set(route.methods)
        if not methods:
            return await error_response(404, f"path: no resource at {scope['path'][:64]!r}", "not_found")(
                scope, receive, send)
        methods |= {"OPTIONS"} | ({"HEAD"} if "GET" in methods else set())
        allow = ", ".join(sorted(methods))
        await Response(status_code=204, headers={"Allow": allow})(scope, receive, send)


def _leaves(routes):
    """The routes themselves, through FastAPI's included routers."""
    for route in routes:
        inner = getattr(route, "original_router", None)
        if inner is not None:
            yield from _leaves(inner.routes)
        else:
            yield route


class Head:
    """Pure ASGI middleware: ``HEAD`` is ``GET`` without the body (RFC 9110, 9.3.2) on every path a GET answers,
    as :class:`Options` advertises. FastAPI's routes take only the methods they declare (Starlette's own add HEAD
    to GET), so HEAD was a 405 there. The GET's headers are sent as they are (Content-Length included: what the
    GET would send) and its body dropped; a path without GET answers 405 as for any other method."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or scope["method"] != "HEAD":
            return await self.app(scope, receive, send)

        async def headers_only(message):
            if message["type"] == "http.response.body":
                if message.get("more_body", False):
                    return
                message = {"type": "http.response.body", "body": b"", "more_body": False}
            await send(message)

        await self.app({**scope, "method": "GET"}, receive, headers_only)


#: on every answer: a browser takes a resource for the type it is served as, never for what its bytes look like
#: (an error's JSON quoting a caller's text is never run as a script or drawn as a page)
NOSNIFF = (b"x-content-type-options", b"nosniff")
#: on a page (text/html) that sets no policy of its own (Swagger UI, ReDoc, the guide): not to be framed by
#: another site (clickjacking: /docs has a field for the API key). The inspector sets a full policy.
NOT_FRAMED = ((b"content-security-policy", b"frame-ancestors 'none'"), (b"x-frame-options", b"DENY"))


class SecurityHeaders:
    """Pure ASGI middleware, outermost: adds :data:`NOSNIFF` to every answer, errors and 500s included, and
    :data:`NOT_FRAMED` to pages without a Content-Security-Policy of their own."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)

        async def send_with_headers(message):
            if message["type"] == "http.response.start":
                headers = list(message.get("headers", []))
                names = {k.lower() for k, _ in headers}
                added = [NOSNIFF] if NOSNIFF[0] not in names else []
                html = any(k.lower() == b"content-type" and v.lower().startswith(b"text/html") for k, v in headers)
                if html and b"content-security-policy" not in names:
                    added += [h for h in NOT_FRAMED if h[0] not in names]
                message = {**message, "headers": headers + added}
            await send(message)

        await self.app(scope, receive, send_with_headers)
