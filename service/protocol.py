"""HTTP details: a deadline on request headers (:class:`HeaderTimeoutProtocol`), and OPTIONS (:class:`Options`).

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
