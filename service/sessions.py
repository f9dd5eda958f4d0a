"""Sessions: a ``dynamics.Simulator`` the server holds for one WebSocket connection (``/v1/sessions``), stepped
by the client one control period at a time.

The protocol is documented for clients in docs/guide/stepping.md ("Over the network"); in short: the first
message (JSON) creates the simulator from a stored robot and a scene (:class:`SessionRequest`); then a binary
frame of little-endian float64 torques steps it and is answered by a binary frame [t (n), q (n, nq), v (n, nv),
failed (n)]; JSON messages reset it, read or set its full state, tell its status and contact forces, or close it
(:data:`CONTROLS`); every refusal is a JSON frame ``{"error": code, "detail", "field", "status"}``.

Here: the registry of the process's sessions (:class:`Sessions`: connections per key, their estimated memory),
the construction of a session (:func:`create`, in a compute thread: it may parse a URDF and allocate n
environments) and a session's answers (:class:`Session`: torques in, arrays out). The route
(:mod:`service.routes.sessions`) only moves frames.

Why the simulator lives in the server process and not in a simulation worker (:mod:`service.sim.pool`): a round
trip through a worker costs about 0.3 ms (docs/architecture.md), the whole budget of one stepped period; the
core's deadline check (every step runs within ``DYNAMICS_TIME_BUDGET``) keeps a runaway period from holding a
thread. What a worker would add, crash isolation, is what sessions give up.
"""

from __future__ import annotations

import json
import logging
import math
import secrets
import time
import warnings
from dataclasses import dataclass, field
from typing import Any, Literal, Optional, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from . import contact as contacts
from . import errors
from . import torque as torques
from .codec import finite_report
from .errors import InvalidInput, Problem, TooLarge, bounded, field_of, is_library_input_error
from .library import lib, parallel
from .models import locked_key
from .scene import simulation_scene
from .schemas import MAX_NAME, Array, ContactSpec, Locked, TorqueSpec, Vec3, validate
from .settings import Settings

log = logging.getLogger("service")

#: a step runs on the event loop when the session's integrator takes a fixed number of steps per period and its
#: last step took less than this (a Panda rk4 period: ~15 us); otherwise in a compute thread (~0.1 ms more)
INLINE_SECONDS = 0.5e-3
#: control messages of sessions of more environments than this run in a compute thread (reset checks every row)
INLINE_ENVIRONMENTS = 64


class TooManySessions(Problem):
    """The key holds DYNAMICS_MAX_SESSIONS_PER_KEY connections to /v1/sessions."""


class IdleTimeout(Problem):
    """No message for DYNAMICS_SESSION_IDLE_TIMEOUT seconds: the server closed the session."""


errors.STATUS.update({TooManySessions: (429, "too_many_sessions"), IdleTimeout: (408, "idle_timeout")})


# -- the messages ---------------------------------------------------------------------------------------------
class _Message(BaseModel):
    # as the HTTP requests: strict, unknown fields refused, no NaN or infinity in numbers
    model_config = ConfigDict(extra="forbid", arbitrary_types_allowed=True, strict=True, allow_inf_nan=False)


class SessionRequest(_Message):
    """The first message of a session: a stored robot and the scene of ``dynamics.Simulator``."""
    model_config = ConfigDict(json_schema_extra={"examples": [
        {"type": "create", "robot": "planar_2r", "q0": [0.3, -0.2], "v0": [0.0, 0.0], "dt": 0.01,
         "integrator": "rk4", "torque": {"type": "pd", "q_target": [0.5, 0.5], "kp": 50.0, "kd": 4.0}}]})
    type: Literal["create"]
    robot: str = Field(min_length=1, max_length=MAX_NAME, description="a stored robot's id or name")
    locked: Locked = None
    q0: Array = Field(description="(nq,) one environment, or (n, nq)")
    v0: Array = Field(description="(nv,) (shared by every environment) or (n, nv)")
    n: Optional[int] = Field(None, ge=1, description="environments, each starting from q0 (nq,): a batch even "
                                                     "when 1 (a failed environment waits; the others go on)")
    dt: float = Field(gt=0, description="the control period, s")
    torque: Optional[TorqueSpec] = None
    contact: Optional[ContactSpec] = None
    integrator: Optional[Literal["euler", "implicit_euler", "rk4", "rk45", "dop853", "radau", "auto"]] = None
    substep: Optional[float] = Field(None, gt=0, description="euler, implicit_euler and rk4: the step inside a period, default dt")
    rtol: Optional[float] = Field(None, gt=0)
    atol: Optional[float] = Field(None, ge=0)
    gravity: Optional[Vec3] = None
    limits: Optional[Literal["spring"]] = None
    limit_stiffness: Optional[float] = Field(None, ge=0)
    limit_damping: Optional[float] = Field(None, ge=0)
    friction_eps: Optional[float] = Field(None, gt=0)
    baumgarte: Optional[list[float]] = Field(None, min_length=2, max_length=2)
    project: Optional[bool] = None


#: the SessionRequest fields passed on to dynamics.Simulator as keyword arguments (None = the library's default)
SIMULATOR_OPTIONS = ("integrator", "substep", "rtol", "atol", "gravity", "limits", "limit_stiffness",
                     "limit_damping", "friction_eps", "baumgarte", "project")

Which = Optional[Union[list[int], list[bool]]]


class Reset(_Message):
    type: Literal["reset"]
    q: Optional[Array] = None
    v: Optional[Array] = None
    which: Which = None
    t: float = 0.0


class SetState(_Message):
    type: Literal["set_state"]
    x: Array
    which: Which = None


class Read(_Message):
    type: Literal["state", "status", "close"]


class ContactForces(_Message):
    type: Literal["contact_forces"]
    env: Optional[int] = Field(None, ge=0)
    details: bool = False


class SessionInfo(BaseModel):
    """One connection to /v1/sessions (``GET /v1/sessions``)."""
    session: Optional[str] = Field(description="the session's id, null while it is being created")
    state: Literal["creating", "open"]
    robot: Optional[str] = None
    n: Optional[int] = Field(None, description="environments")
    nq: Optional[int] = None
    nv: Optional[int] = None
    dt: Optional[float] = None
    integrator: Optional[str] = None
    steps: Optional[int] = Field(None, description="step messages answered")
    bytes: Optional[int] = Field(None, description="the memory estimated for its simulator")
    age_s: float = Field(description="seconds since the connection opened")
    idle_s: float = Field(description="seconds since its last message")


class SessionsAnswer(BaseModel):
    sessions: list[SessionInfo] = Field(description="the caller's connections to /v1/sessions (every one when the "
                                                    "server has no API keys)")
    limit: int = Field(description="DYNAMICS_MAX_SESSIONS_PER_KEY")
    idle_timeout: float = Field(description="DYNAMICS_SESSION_IDLE_TIMEOUT, s")


#: the JSON messages of an open session, by type
CONTROLS: dict[str, type[_Message]] = {"reset": Reset, "set_state": SetState, "state": Read, "status": Read,
                                       "contact_forces": ContactForces, "close": Read}


def error_frame(problem: Problem) -> dict[str, Any]:
    """The JSON frame of a refusal: the HTTP error's body (detail, code as ``error``, field) and its status."""
    status, code = errors.STATUS[type(problem)]
    return {"error": problem.code or code, "detail": bounded(problem.detail), "field": problem.field,
            "status": status}


async def deny(receive, send, problem: Problem) -> None:
    """Refuse a WebSocket connection before it holds a session (no key, too many sessions): accepted, told why in
    an error frame, and closed with the code 4000 + the error's HTTP status. (Not an HTTP answer to the handshake:
    uvicorn's default WebSocket protocol logs every such answer as an error of the app.)"""
    if (await receive())["type"] != "websocket.connect":
        return
    frame = error_frame(problem)
    await send({"type": "websocket.accept"})
    await send({"type": "websocket.send", "text": json.dumps(frame)})
    await send({"type": "websocket.close", "code": 4000 + frame["status"]})


def as_problem(exc: BaseException, budget: float) -> Optional[Problem]:
    """A session's exception as the service's refusal: its own problems, the library's input errors (422 naming
    the argument) and its deadline (504: the step ran past ``budget`` seconds); None for anything else (a bug)."""
    if isinstance(exc, Problem):
        return exc
    if isinstance(exc, lib().DeadlineExceeded):
        return errors.BudgetExceeded("the step", budget, "step fewer environments, use a larger substep or loosen "
                                                         "rtol/atol; environments not stepped stay at their period's "
                                                         "start")
    if is_library_input_error(exc):
        return InvalidInput(str(exc), field_of(str(exc)))
    return None


# -- memory -------------------------------------------------------------------------------------------------
def estimate_bytes(model, n: int, contact: bool) -> int:
    """The memory of a simulator of ``n`` environments, estimated before it is built (measured RSS per
    environment of chains of 2 to 128 joints and the Panda, rounded up by a quarter: 4 KiB + 4 KiB nv + 64 B nv^2,
    the core's workspaces and the integrator's state; contact 2 KiB + 3 KiB per body, its per-environment scene)."""
    nv = model.nv
    per = 5 * 1024 + 5 * 1024 * nv + 80 * nv * nv + 8 * (2 + model.nq + 2 * nv)
    if contact:
        per += 3 * 1024 + 4 * 1024 * len(model.body_names)
    return n * per


# -- a session ------------------------------------------------------------------------------------------------
class Session:
    """One simulator and its frames. ``step`` and ``control`` are plain calls (the route runs them inline or in a
    compute thread, never two at once for one session)."""

    def __init__(self, sim, robot: str, scene: dict[str, Any], contact: bool, settings: Settings, size: int):
        self.id = secrets.token_hex(8)
        self.sim, self.robot, self.scene, self.contact, self.bytes = sim, robot, scene, contact, size
        model = sim.model
        self.n, self.nq, self.nv, self.batched = sim.n, model.nq, model.nv, sim.batched
        self.budget = settings.time_budget
        self.fixed = sim.integrator in ("euler", "implicit_euler", "rk4")
        self.last_step = math.inf  # seconds of the last step: the first runs in a thread
        self.steps = 0
        # the width of a row of Simulator.state() ([t, q, v, h, phase, t_origin, periods]), the library's own
        self.state_size = int(np.shape(sim.state())[-1])
        n, nq, nv = self.n, self.nq, self.nv
        # the answer of a step, written in place: [t (n), q (n, nq), v (n, nv), failed (n)], float64 little-endian
        self._answer = np.zeros(n * (2 + nq + nv), dtype="<f8")
        a = self._answer
        self._t, self._q = a[:n], a[n:n + n * nq].reshape(n, nq)
        self._v, self._failed = a[n + n * nq:n + n * (nq + nv)].reshape(n, nv), a[n * (1 + nq + nv):]

    def hello(self, idle_timeout: float) -> dict[str, Any]:
        """The answer to the create message: the sizes and the binary layouts."""
        n, nq, nv, sim = self.n, self.nq, self.nv, self.sim
        return {"type": "created", "session": self.id, "robot": self.robot, "nq": nq, "nv": nv, "n": n,
                "batched": self.batched, "dt": sim.dt, "integrator": sim.integrator, "substep": sim.substep,
                "joint_names": list(sim.model.joint_names), "contact": self.contact,
                "scene": self.scene, "idle_timeout": idle_timeout, "bytes": self.bytes,
                "layout": {"dtype": "<f8", "step": [["tau", [n, nv]]],
                           "answer": [["t", [n]], ["q", [n, nq]], ["v", [n, nv]], ["failed", [n]]],
                           "state": [["x", [n, self.state_size]]]}}

    def inline(self) -> bool:
        """Whether the next step may run on the event loop: a fixed-step method whose last step was short."""
        return self.fixed and self.last_step < INLINE_SECONDS

    def step(self, frame: bytes) -> bytes:
        """A step frame (n nv or nv float64, or empty) -> the answer frame, within the time budget."""
        tau = self._torque(frame)
        tic = time.perf_counter()
        try:
            with parallel().deadline(time.monotonic() + self.budget):
                self.sim.step(tau)
        finally:
            self.last_step = time.perf_counter() - tic
        self.steps += 1
        return self._state_frame()

    def _torque(self, frame: bytes) -> Optional[np.ndarray]:
        size, n, nv = len(frame), self.n, self.nv
        if size == 0:
            return None
        if size == 8 * nv:
            return np.frombuffer(frame, dtype="<f8")
        if size == 8 * n * nv:
            return np.frombuffer(frame, dtype="<f8").reshape(n, nv)
        if n > 1:
            sizes = (f"{n} x {nv} = {n * nv} little-endian float64 ({8 * n * nv} bytes), {nv} ({8 * nv} bytes, one "
                     f"torque for every environment)")
        else:
            sizes = f"{nv} little-endian float64 ({8 * nv} bytes)"
        raise InvalidInput(f"tau: a step frame holds {sizes} or nothing (zero torque); got {size} bytes", "tau")

    def _state_frame(self) -> bytes:
        sim = self.sim
        self._t[:] = sim.t
        self._q[:] = sim.q
        self._v[:] = sim.v
        self._failed[:] = sim.failed
        return self._answer.tobytes()

    def control_inline(self) -> bool:
        return self.n <= INLINE_ENVIRONMENTS

    def control(self, message: _Message) -> Union[bytes, dict[str, Any]]:
        """A validated control message (not close) -> its answer: a binary frame or a JSON object."""
        sim = self.sim
        if isinstance(message, Reset):
            sim.reset(message.q, message.v, which=message.which, t=message.t)
            return self._state_frame()
        if isinstance(message, SetState):
            sim.set_state(message.x, which=message.which)
            return self._state_frame()
        if isinstance(message, ContactForces):
            return self._contact_forces(message.env, message.details)
        if message.type == "state":
            return np.ascontiguousarray(sim.state(), dtype="<f8").tobytes()
        return self._status()

    def _status(self) -> dict[str, Any]:
        sim = self.sim

        def rows(x: Any) -> list:
            return np.atleast_1d(x).tolist()

        energy = np.asarray(sim.energy).reshape(self.n, 2)
        work = np.asarray(sim.work).reshape(self.n, -1)
        status = sim.status
        return finite_report({"type": "status", "t": rows(sim.t), "failed": rows(sim.failed),
                              "status": status if self.batched else [status], "error_estimate": rows(sim.error),
                              "energy": energy, "work": work, "stats": sim.stats, "steps": self.steps})

    def _contact_forces(self, env: Optional[int], details: bool) -> dict[str, Any]:
        if env is None and self.batched and self.n == 1:
            env = 0
        out = self.sim.contact_forces(env, details=details)
        f_ext, more = (out if details else (out, None))
        answer: dict[str, Any] = {"type": "contact_forces", "f_ext": np.asarray(f_ext),
                                  "bodies": list(self.sim.model.body_names)}
        if more is not None:
            answer["details"] = {k: ([list(p) for p in v] if k == "pairs" else v) for k, v in more._asdict().items()}
        return finite_report(answer)

    def listing(self) -> dict[str, Any]:
        sim = self.sim
        return {"session": self.id, "robot": self.robot, "n": self.n, "nq": self.nq, "nv": self.nv, "dt": sim.dt,
                "integrator": sim.integrator, "steps": self.steps, "bytes": self.bytes}


def control_message(payload: Any) -> _Message:
    """A decoded JSON message of an open session -> its validated form (a 422 naming the field otherwise)."""
    if not isinstance(payload, dict):
        raise InvalidInput(f"message: expected a JSON object {{\"type\": ...}}, got {type(payload).__name__}",
                           "message")
    kind = payload.get("type")
    if kind == "create":
        raise InvalidInput("type: this connection already holds a session (one per connection); open another "
                           "connection for another", "type")
    model = CONTROLS.get(kind) if isinstance(kind, str) else None
    if model is None:
        raise InvalidInput(f"type: expected one of {sorted(CONTROLS)} (or a binary frame of torques to step), "
                           f"got {str(kind)[:40]!r}", "type")
    return validate(model, payload)


# -- building one -------------------------------------------------------------------------------------------
_quiet = False


def _quiet_warnings() -> None:
    """The library's SimulationWarnings of sessions are not the server's to print (a client could fill its log
    with failing periods): a client reads them as ``failed`` and the status message."""
    global _quiet
    if not _quiet:
        warnings.filterwarnings("ignore", category=lib().SimulationWarning, module=__name__)
        _quiet = True


def create(deps, owner: Optional[str], payload: Any) -> Session:
    """The create message (decoded JSON) -> a session, in a compute thread: the robot as the caller may see it
    (404 otherwise), its model (cached, or parsed), the service's limits (environments, memory), the torque and
    contact specs through the same translations as /simulate, then the library's Simulator (its checks name the
    argument: "q0: expected shape (2,) or (N, 2), got (3,)")."""
    _quiet_warnings()
    s = deps.settings
    if not isinstance(payload, dict):
        raise InvalidInput(f"message: the first message creates the session: a JSON object {{\"type\": \"create\", "
                           f"\"robot\": ..., ...}}, got {type(payload).__name__}", "message")
    if payload.get("type") != "create":
        raise InvalidInput(f"type: the first message creates the session: {{\"type\": \"create\", \"robot\": ..., "
                           f"...}}, got type {str(payload.get('type'))[:40]!r}", "type")
    req: SessionRequest = validate(SessionRequest, payload)
    rid = deps.catalog.resolve(req.robot, owner)
    entry = deps.models.loaded(rid, locked_key(req.locked))
    model = entry.model
    q0 = req.q0
    if req.n is not None:
        if q0.ndim == 1:
            q0 = np.broadcast_to(q0, (req.n, q0.shape[0]))
        elif q0.shape[0] != req.n:
            raise InvalidInput(f"n: {req.n} environments, but q0 has {q0.shape[0]} rows", "n")
    n = q0.shape[0] if q0.ndim == 2 else 1
    if n > s.max_batch:
        raise InvalidInput(f"q0: {n} environments is over the limit of {s.max_batch} (DYNAMICS_MAX_BATCH)", "q0")
    size = estimate_bytes(model, n, req.contact is not None)
    if size > s.max_session_bytes:
        raise TooLarge(f"n: {n} environments of {rid!r} need about {size} bytes, over the limit of "
                       f"{s.max_session_bytes} (DYNAMICS_MAX_SESSION_BYTES); step fewer environments per session",
                       "n")
    options = {k: getattr(req, k) for k in SIMULATOR_OPTIONS if getattr(req, k) is not None}
    contact = req.contact.model_dump(exclude_none=True) if req.contact is not None else None
    contacts.check_frames(model, contact)
    try:
        torque = torques.build(req.torque.model_dump() if req.torque is not None else None)
        sim = lib().Simulator(model, q0, req.v0, dt=req.dt, torque=torque, contact=contacts.build(contact),
                              max_steps=s.max_sim_steps, **options)
    except ValueError as e:
        if not is_library_input_error(e):
            raise
        message = contacts.qualify(str(e)) if contact is not None else str(e)
        raise InvalidInput(message, field_of(message)) from None
    return Session(sim, rid, simulation_scene(entry.scene, model.gravity, req.gravity), contact is not None, s,
                   size)


# -- the registry -------------------------------------------------------------------------------------------
@dataclass(eq=False)
class Ticket:
    """One connection to /v1/sessions, counted against its key from its handshake to its end."""
    owner: Optional[str]
    opened: float = field(default_factory=time.monotonic)
    active: float = field(default_factory=time.monotonic)  # when its last message arrived
    session: Optional[Session] = None


class Sessions:
    """The sessions of this server process, per key. Used from the event loop only (no lock)."""

    def __init__(self, settings: Settings):
        self.settings = settings
        self._held: dict[Optional[str], set[Ticket]] = {}

    def admit(self, owner: Optional[str]) -> Ticket:
        """A ticket for a new connection, or a 429 when the key holds DYNAMICS_MAX_SESSIONS_PER_KEY already."""
        held = self._held.setdefault(owner, set())
        limit = self.settings.max_sessions_per_key
        if len(held) >= limit:
            raise TooManySessions(f"sessions: this key has {len(held)} sessions open, the limit "
                                  f"(DYNAMICS_MAX_SESSIONS_PER_KEY); close one first (idle ones close after "
                                  f"{self.settings.session_idle_timeout:g} s)", "sessions",
                                  headers={"Retry-After": "1"})
        ticket = Ticket(owner)
        held.add(ticket)
        return ticket

    def release(self, ticket: Ticket) -> int:
        """Forget a connection and its session; the bytes its session was estimated to hold."""
        held = self._held.get(ticket.owner)
        if held is not None:
            held.discard(ticket)
            if not held:
                del self._held[ticket.owner]
        freed = ticket.session.bytes if ticket.session is not None else 0
        ticket.session = None
        return freed

    def __len__(self) -> int:
        return sum(len(h) for h in self._held.values())

    def listing(self, owner: Optional[str]) -> dict[str, Any]:
        """``GET /v1/sessions``: the caller's connections (all of them when keys are off)."""
        now = time.monotonic()
        rows = []
        for t in sorted(self._held.get(owner, ()), key=lambda t: t.opened):
            row = t.session.listing() if t.session is not None else {"session": None}
            rows.append({**row, "state": "open" if t.session is not None else "creating",
                         "age_s": round(now - t.opened, 3), "idle_s": round(now - t.active, 3)})
        return {"sessions": rows, "limit": self.settings.max_sessions_per_key,
                "idle_timeout": self.settings.session_idle_timeout}

    def close(self) -> None:
        self._held.clear()
