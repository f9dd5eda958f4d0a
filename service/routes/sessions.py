"""``/v1/sessions``: a simulator stepped over a WebSocket, one session per connection (:mod:`service.sessions`
has the protocol's messages and the numbers; docs/guide/stepping.md documents it for clients), and ``GET
/v1/sessions``, the caller's open sessions.

The connection is counted against its key from its handshake (past the limit it is refused at once: an error
frame, 429, and closed) to its end, whatever ends it: a close message, an idle timeout, the client gone (also
while a step runs in a thread: the answer is dropped and the session freed), a refused create. A bad message is answered by an error
frame and the session goes on; only a refused create, an idle timeout and a bug (500) end it, each after its
error frame, with the close code 4000 + the error's HTTP status.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Any, Optional

import orjson
from fastapi import APIRouter, Request, WebSocket
from starlette.responses import Response
from starlette.websockets import WebSocketDisconnect

from .. import memory
from ..auth import caller
from ..codec import JSON, jsonable
from ..compute import Budget
from ..errors import Failed, InvalidInput, Problem
from ..sessions import (IdleTimeout, Session, Sessions, SessionsAnswer, TooManySessions, as_problem,
                        control_message, create, deny, error_frame)

log = logging.getLogger("service")
router = APIRouter(prefix="/v1")
PATH = "/sessions"


@router.get(PATH, response_model=SessionsAnswer,
            summary="the caller's open sessions (WebSocket /v1/sessions: a simulator stepped by the client)")
async def list_sessions(request: Request) -> Response:
    sessions: Sessions = request.app.state.sessions
    return Response(orjson.dumps(sessions.listing(caller(request))), media_type=JSON)


class _Closed(Exception):
    """The connection ended (the client left, or the server closed it after an error frame)."""


@router.websocket(PATH)
async def session(ws: WebSocket) -> None:
    registry: Sessions = ws.app.state.sessions
    try:
        ticket = registry.admit(caller(ws))
    except TooManySessions as e:
        return await deny(ws.receive, ws.send, e)
    d = ws.app.state.deps
    idle = d.settings.session_idle_timeout
    try:
        await ws.accept()
        first = await _receive(ws, min(idle, d.settings.read_timeout))
        ticket.active = time.monotonic()
        try:
            payload = _json(first)
            budget = Budget.starting_now(d.settings.time_budget)
            ticket.session = await d.compute.run_within(budget, create, d, ticket.owner, payload)
        except Exception as e:  # noqa: BLE001 - a refused create ends the connection, after saying why
            await _refuse(ws, e, d.settings.time_budget, end=True)
        await _send(ws, _dumps(ticket.session.hello(idle)))
        await _serve(ws, ticket, d, idle)
    except _Closed:
        pass
    finally:
        freed = registry.release(ticket)
        if freed and (len(registry) == 0 or freed >= memory.RELEASE_BYTES):
            # the simulator's arrays back to the system (the RSS to its baseline), once the last session is gone
            try:
                await asyncio.shield(d.compute.run(memory.release))
            except RuntimeError:  # (the server is shutting down: its threads are gone)
                pass


async def _serve(ws: WebSocket, ticket, d, idle: float) -> None:
    """The session's messages, one at a time, in order: a binary frame steps, a JSON one is a control message."""
    s: Session = ticket.session
    budget = d.settings.time_budget
    while True:
        message = await _receive(ws, idle)
        ticket.active = time.monotonic()
        frame = message.get("bytes")
        try:
            if frame is not None:
                answer: Any = s.step(frame) if s.inline() else await d.compute.run(s.step, frame)
            else:
                control = control_message(_json(message))
                if control.type == "close":
                    await _send(ws, b'{"type":"closed"}', text=True)
                    await _close(ws, 1000)
                answer = s.control(control) if s.control_inline() else await d.compute.run(s.control, control)
        except _Closed:
            raise
        except Exception as e:  # noqa: BLE001 - answered as an error frame; the session goes on
            await _refuse(ws, e, budget)
            continue
        await _send(ws, answer if isinstance(answer, bytes) else _dumps(answer), text=not isinstance(answer, bytes))


async def _receive(ws: WebSocket, timeout: float) -> dict[str, Any]:
    """The next message, or _Closed when the client left or stayed silent for ``timeout`` seconds (then told
    so, and the connection closed)."""
    try:
        async with asyncio.timeout(timeout):
            message = await ws.receive()
    except TimeoutError:
        await _refuse(ws, IdleTimeout(f"session: no message for {timeout:g} s (DYNAMICS_SESSION_IDLE_TIMEOUT, or "
                                      f"DYNAMICS_READ_TIMEOUT for the first one); the session is closed and its "
                                      f"simulator freed", "session"), 0.0, end=True)
    if message["type"] == "websocket.disconnect":
        raise _Closed
    return message


def _json(message: dict[str, Any]) -> Any:
    text = message.get("text")
    if text is None:
        raise InvalidInput("message: expected a JSON text frame here (binary frames step an open session)",
                           "message")
    try:
        return orjson.loads(text)
    except orjson.JSONDecodeError as e:
        raise InvalidInput(f"message: not JSON ({e})", "message") from None


def _dumps(obj: Any) -> bytes:
    return orjson.dumps(obj, default=jsonable, option=orjson.OPT_SERIALIZE_NUMPY)


async def _send(ws: WebSocket, data: bytes, *, text: bool = True) -> None:
    try:
        if text:
            await ws.send({"type": "websocket.send", "text": data.decode()})
        else:
            await ws.send({"type": "websocket.send", "bytes": data})
    except (WebSocketDisconnect, OSError, RuntimeError):  # the client left (while the answer was computed)
        raise _Closed from None


async def _refuse(ws: WebSocket, exc: BaseException, budget: float, *, end: bool = False) -> None:
    """An error frame for ``exc`` (a bug: logged, 500, and the connection ends); with ``end`` the connection is
    closed after it, with the code 4000 + its HTTP status."""
    problem: Optional[Problem] = as_problem(exc, budget)
    if problem is None:
        log.error("session: unexpected error", exc_info=(type(exc), exc, exc.__traceback__))
        problem, end = Failed(f"internal error ({type(exc).__name__}): this is a bug, please report it"), True
    frame = error_frame(problem)
    await _send(ws, _dumps(frame))
    if end:
        await _close(ws, 4000 + frame["status"])


async def _close(ws: WebSocket, code: int) -> None:
    """Close the connection (if the client is still there) and end the session: raises _Closed."""
    try:
        await ws.close(code)
    except (WebSocketDisconnect, OSError, RuntimeError):
        pass
    raise _Closed
