"""API keys: with keys configured, every request (and every WebSocket handshake: ``/v1/sessions``) but the open
paths (health, readiness, and the inspector page's files under ``/inspect``: code, no data; the page sends the key
the user types with its API calls) needs a Bearer key.

Pure ASGI middleware (no per-request objects): it runs before routing and puts the caller's owner tag
(:func:`service.store.owner_tag`, what the store remembers of a key) in the scope, read by :func:`caller`.
"""

from __future__ import annotations

import hmac
from typing import Optional

from starlette.requests import HTTPConnection

from .errors import Unauthorized, problem_response
from .store import owner_tag

OWNER = "dynamics.owner"


class ApiKeys:
    """Every configured key is compared in constant time, so the answer's timing tells nothing about the keys."""

    def __init__(self, app, keys: tuple[str, ...], open_paths: tuple[str, ...] = (), open_prefix: str = "",
                 closed_paths: tuple[str, ...] = ()):
        self.app = app
        self.keys = [k.encode() for k in keys]
        self.open_paths = frozenset(open_paths)
        self.open_prefix = open_prefix or None
        self.closed_paths = frozenset(closed_paths)  # under the open prefix, yet holding data: keyed

    async def __call__(self, scope, receive, send):
        if (scope["type"] not in ("http", "websocket") or not self.keys or scope["path"] in self.open_paths
                or self._open(scope["path"])):
            return await self.app(scope, receive, send)
        given = b""
        for name, value in scope["headers"]:
            if name == b"authorization":
                scheme, _, token = value.partition(b" ")
                if scheme.lower() == b"bearer":
                    given = token.strip()
                break
        match = None
        for key in self.keys:
            if hmac.compare_digest(key, given):
                match = key
        if match is None:
            detail = "Authorization: a valid 'Bearer <key>' header is required" if given else \
                "Authorization: missing; send 'Authorization: Bearer <key>'"
            refusal = Unauthorized(detail, "Authorization", headers={"WWW-Authenticate": "Bearer"})
            if scope["type"] == "websocket":  # (refused in the sessions' protocol: an error frame, then closed)
                from .sessions import deny
                return await deny(receive, send, refusal)
            return await problem_response(refusal)(scope, receive, send)
        scope[OWNER] = owner_tag(match.decode())
        return await self.app(scope, receive, send)

    def _open(self, path: str) -> bool:
        """Under the open prefix: the prefix itself or one of its sub-paths (not '/inspector'), but no closed path."""
        p = self.open_prefix
        return (p is not None and path.startswith(p) and (len(path) == len(p) or path[len(p)] == "/")
                and path not in self.closed_paths)


def caller(request: HTTPConnection) -> Optional[str]:
    """The owner tag of the caller's API key, None when keys are off (a FastAPI dependency; a WebSocket too)."""
    return request.scope.get(OWNER)
