"""API keys: with keys configured, every request but the open paths (health, readiness) needs a Bearer key.

Pure ASGI middleware (no per-request objects): it runs before routing and puts the caller's owner tag
(:func:`service.store.owner_tag`, what the store remembers of a key) in the scope, read by :func:`caller`.
"""

from __future__ import annotations

import hmac
from typing import Optional

from starlette.requests import Request

from .errors import Unauthorized, problem_response
from .store import owner_tag

OWNER = "dynamics.owner"


class ApiKeys:
    """Every configured key is compared in constant time, so the answer's timing tells nothing about the keys."""

    def __init__(self, app, keys: tuple[str, ...], open_paths: tuple[str, ...] = ()):
        self.app = app
        self.keys = [k.encode() for k in keys]
        self.open_paths = frozenset(open_paths)

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or not self.keys or scope["path"] in self.open_paths:
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
            return await problem_response(refusal)(scope, receive, send)
        scope[OWNER] = owner_tag(match.decode())
        return await self.app(scope, receive, send)


def caller(request: Request) -> Optional[str]:
    """The owner tag of the caller's API key, None when keys are off (a FastAPI dependency)."""
    return request.scope.get(OWNER)
