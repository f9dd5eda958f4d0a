"""The FastAPI application: routes only. No numeric code lives here (see :mod:`service.compute`).

Dependencies (store, model cache, thread pool, simulation pool, settings) are built once per process in the
lifespan and reached through :func:`services`; a test or another deployment can pass its own ``Settings`` to
:func:`create_app`. Request bodies are read by :func:`service.codec.read_body` (size limit enforced while
reading) and decoded in the worker thread together with the computation, so that neither parsing megabytes
of JSON nor the numbers block the event loop.
"""

from __future__ import annotations

import asyncio
import hmac
import json
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import asynccontextmanager
from dataclasses import dataclass
from typing import Any, Optional

from fastapi import APIRouter, Depends, FastAPI, Query, Request
from fastapi.openapi.utils import get_openapi
from pydantic import BaseModel, ValidationError
from starlette.responses import Response

from . import __version__, schemas
from .codec import JSON, NPZ, XML_TYPES, decode, encode, media_type, read_body
from .compute import INLINE_BYTES, BudgetExceeded, Compute, Operation, locked_key, operations, simulation_scene
from .errors import ApiError, bad_input, error_response, field_of, install_handlers
from .robots import delete_robot, list_robots, register_robot, robot_info
from .settings import Settings
from .simpool import PoolBusy, PoolTimeout, SimPool, WorkerCrashed
from .store import RobotStore, owner_tag

HEALTH_PATH = "/v1/health"


@dataclass
class Services:
    settings: Settings
    store: RobotStore
    compute: Compute
    ops: dict[str, Operation]
    sim: Optional[SimPool]
    sim_waiters: ThreadPoolExecutor

    @classmethod
    def start(cls, settings: Settings) -> "Services":
        from .simjob import simulate_function

        store = RobotStore(settings.store_dir, settings.robots_dir)
        # DYNAMICS_SIM_WORKERS=0 turns simulation off (each worker compiles the integrator when it starts).
        sim = SimPool(settings.sim_workers) if settings.sim_workers > 0 and simulate_function() else None
        return cls(settings=settings, store=store, compute=Compute(settings, store), ops=operations(), sim=sim,
                   sim_waiters=ThreadPoolExecutor(max_workers=max(1, 4 * settings.sim_workers),
                                                  thread_name_prefix="sim-wait"))

    def close(self) -> None:
        self.compute.close()
        if self.sim is not None:
            self.sim.close()
        self.sim_waiters.shutdown(wait=False, cancel_futures=True)


def services(request: Request) -> Services:
    return request.app.state.services


def caller(request: Request) -> Optional[str]:
    """The owner tag of the caller's API key (set by :class:`ApiKeys`), None when keys are off."""
    return request.scope.get("dynamics.owner")


class ApiKeys:
    """Pure ASGI middleware: with keys configured, every request but the health check needs a Bearer key.

    Every configured key is compared in constant time, so the answer's timing tells nothing about the keys.
    """

    def __init__(self, app, keys: tuple[str, ...]):
        self.app = app
        self.keys = [k.encode() for k in keys]

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http" or not self.keys or scope["path"] == HEALTH_PATH:
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
            resp = error_response(401, detail, "unauthorized", "Authorization", {"WWW-Authenticate": "Bearer"})
            return await resp(scope, receive, send)
        scope["dynamics.owner"] = owner_tag(match.decode())
        return await self.app(scope, receive, send)


def deadline_of(request: Request, settings: Settings) -> float:
    """Now + the request's wall-time budget: the server's, or less if the caller asks (X-Time-Budget: s)."""
    budget = settings.time_budget
    asked = request.headers.get("x-time-budget")
    if asked is not None:
        try:
            value = float(asked)
        except ValueError:
            value = float("nan")
        if not value > 0:
            raise bad_input(f"X-Time-Budget: expected a positive number of seconds, got {asked!r}", "X-Time-Budget")
        budget = min(budget, value)
    request.state.budget = budget
    return time.monotonic() + budget


def validate(schema: type[BaseModel], payload: dict[str, Any]) -> BaseModel:
    """A decoded body -> the schema, or a 422 whose message starts with the field at fault."""
    try:
        return schema.model_validate(payload)
    except ValidationError as e:
        err = e.errors(include_url=False)[0]
        name = ".".join(str(p) for p in err["loc"]) or "body"
        if err["type"] == "extra_forbidden":
            allowed = ", ".join(schema.model_fields)
            raise bad_input(f"{name}: unknown field; expected one of {allowed}", name) from None
        if err["type"] == "union_tag_invalid":
            ctx = err.get("ctx", {})
            raise bad_input(f"{name}.type: {ctx.get('tag')!r} is not one of {ctx.get('expected_tags')}",
                            f"{name}.type") from None
        if err["type"] == "missing":
            raise bad_input(f"{name}: missing (required)", name) from None
        raise bad_input(f"{name}: {err['msg']}", name) from None


def _body_doc(schema: type[BaseModel], npz: bool = True) -> dict[str, Any]:
    ref = {"$ref": f"#/components/schemas/{schema.__name__}"}
    content = {JSON: {"schema": ref}}
    if npz:
        content[NPZ] = {"schema": {"type": "string", "format": "binary",
                                   "description": "numpy .npz archive, one member per field (no pickles)"}}
    return {"requestBody": {"required": True, "content": content}}


_ERRORS = {status: {"model": schemas.ErrorAnswer} for status in (401, 404, 413, 415, 422, 504)}

# url segment -> (request schema, answer schema, summary)
_DYNAMICS_ROUTES: dict[str, tuple[type[BaseModel], type[BaseModel], str]] = {
    "inverse-dynamics": (schemas.InverseDynamicsRequest, schemas.TauAnswer, "tau = ID(q, v, a) by RNEA"),
    "forward-dynamics": (schemas.ForwardDynamicsRequest, schemas.AccelerationAnswer, "a = FD(q, v, tau) by ABA"),
    "mass-matrix": (schemas.MassMatrixRequest, schemas.MassMatrixAnswer, "M(q) by CRBA"),
    "gravity-torques": (schemas.GravityTorquesRequest, schemas.TauAnswer, "g(q) = ID(q, 0, 0)"),
    "bias-forces": (schemas.BiasForcesRequest, schemas.TauAnswer, "h(q, v) = ID(q, v, 0)"),
}

router = APIRouter(prefix="/v1")


@router.get("/health", summary="liveness: 200 when the server answers")
async def health() -> Response:
    return Response(b'{"status":"ok"}', media_type=JSON)


@router.post("/robots", status_code=201, response_model=schemas.UploadAnswer, responses=_ERRORS,
             openapi_extra={"requestBody": {"required": True, "content": {
                 "application/xml": {"schema": {"type": "string", "description": "the URDF document"}},
                 JSON: {"schema": {"$ref": "#/components/schemas/UploadRequest"}}}}},
             summary="upload a URDF; the id derives from content and options (same upload, same id)")
async def upload(request: Request, name: Optional[str] = Query(None, max_length=128),
                 floating_base: bool = Query(False), svc: Services = Depends(services),
                 owner: Optional[str] = Depends(caller)) -> Response:
    body = await read_body(request, svc.settings.max_body_bytes)
    kind = media_type(request.headers.get("content-type"))
    if kind in XML_TYPES:
        urdf = body
    elif kind == JSON or not kind:
        req = validate(schemas.UploadRequest, decode(body, JSON, max_unpacked=0))
        urdf, name, floating_base = req.urdf.encode("utf-8"), req.name or name, req.floating_base
    else:
        raise ApiError(415, f"Content-Type: {kind!r} is not accepted; send the URDF as application/xml, or "
                            f"JSON {{\"urdf\": ...}}", code="unsupported_media_type", field="Content-Type")
    info = await svc.compute.run(register_robot, svc, urdf, name, floating_base, owner)
    return Response(json.dumps(info).encode(), status_code=201, media_type=JSON,
                    headers={"Location": f"/v1/robots/{info['id']}"})


@router.get("/robots", response_model=schemas.RobotList, responses=_ERRORS, summary="every robot")
async def robots(svc: Services = Depends(services)) -> Response:
    return Response(json.dumps({"robots": await svc.compute.run(list_robots, svc)}).encode(), media_type=JSON)


@router.get("/robots/{robot_id}", response_model=schemas.RobotInfo, responses=_ERRORS,
            summary="joints (types, limits, damping) and bodies of one robot")
async def robot(robot_id: str, svc: Services = Depends(services)) -> Response:
    return Response(json.dumps(await svc.compute.run(robot_info, svc, robot_id)).encode(), media_type=JSON)


@router.delete("/robots/{robot_id}", status_code=204, responses={**_ERRORS, 403: {"model": schemas.ErrorAnswer}},
               summary="delete an uploaded robot (with the key that uploaded it); bundled robots stay")
async def delete(robot_id: str, svc: Services = Depends(services),
                 owner: Optional[str] = Depends(caller)) -> Response:
    await svc.compute.run(delete_robot, svc, robot_id, owner)
    return Response(status_code=204)


def _dynamics_route(segment: str, schema: type[BaseModel]):
    async def route(robot_id: str, request: Request) -> Response:
        svc: Services = request.app.state.services  # (not Depends: it costs ~50 us on the hottest path)
        deadline = deadline_of(request, svc.settings)
        body = await read_body(request, svc.settings.max_body_bytes)
        content_type, accept = request.headers.get("content-type"), request.headers.get("accept")
        op = svc.ops[segment]
        if len(body) <= INLINE_BYTES:
            # A tiny request (one state, a handful of states) costs ~20-40 us of parsing and compiled work:
            # less than the thread hop itself, so it runs here once its kernel is known to be compiled and
            # its model cached (the first call of each kind goes to a thread: a compilation or a URDF parse
            # must never stall the loop).
            args = dict(validate(schema, decode(body, content_type, max_unpacked=INLINE_BYTES)))
            if svc.compute.can_inline(op, robot_id, args):
                return encode(svc.compute.dynamics(op, robot_id, args, deadline, request.state.budget), accept)
            result = await svc.compute.run(svc.compute.dynamics, op, robot_id, args, deadline, request.state.budget)
            return encode(result, accept)
        return await svc.compute.run(_answer_dynamics, svc, op, schema, robot_id, body, content_type, accept,
                                     deadline, request.state.budget)

    route.__name__ = segment.replace("-", "_")
    return route


def _answer_dynamics(svc: Services, op: Operation, schema: type[BaseModel], robot_id: str, body: bytes,
                     content_type: Optional[str], accept: Optional[str], deadline: float,
                     budget: float) -> Response:
    """Runs in a compute thread: decode, check, compute (chunked, within the deadline), encode."""
    payload = decode(body, content_type, max_unpacked=8 * svc.settings.max_body_bytes)
    req = validate(schema, payload)
    result = svc.compute.dynamics(op, robot_id, dict(req), deadline, budget)
    return encode(result, accept)


for _segment, (_schema, _answer, _summary) in _DYNAMICS_ROUTES.items():
    router.add_api_route(f"/robots/{{robot_id}}/{_segment}", _dynamics_route(_segment, _schema), methods=["POST"],
                         response_model=_answer, responses=_ERRORS, openapi_extra=_body_doc(_schema),
                         summary=_summary)


@router.post("/robots/{robot_id}/simulate", response_model=schemas.TrajectoryAnswer,
             responses={**_ERRORS, 501: {"model": schemas.ErrorAnswer}},
             openapi_extra=_body_doc(schemas.SimulateRequest),
             summary="simulate from (q0, v0) for a duration under a torque law; runs in a worker process")
async def simulate(robot_id: str, request: Request, svc: Services = Depends(services)) -> Response:
    deadline = deadline_of(request, svc.settings)
    body = await read_body(request, svc.settings.max_body_bytes)
    if svc.sim is None:
        raise ApiError(501, "simulate: not available on this server (DYNAMICS_SIM_WORKERS=0, or a build of "
                            "dynamics without simulate())", code="not_implemented")
    job, scene = await svc.compute.run(_simulation_job, svc, robot_id, body, request.headers.get("content-type"))
    loop = asyncio.get_running_loop()
    try:
        answer = await loop.run_in_executor(svc.sim_waiters, svc.sim.run, job, deadline)
    except PoolTimeout:
        raise BudgetExceeded(f"the simulation of {job['duration']:g} s", request.state.budget,
                             "shorten the duration, loosen rtol/atol or use a larger dt") from None
    except PoolBusy as e:
        raise ApiError(503, f"simulate: {e}; retry shortly", code="starting" if e.starting else "busy",
                       headers={"Retry-After": "5" if e.starting else "1"}) from None
    except WorkerCrashed as e:
        raise ApiError(500, f"simulate: {e}", code="worker_crashed") from None
    if "input_error" in answer:
        msg = answer["input_error"]
        raise bad_input(msg, field_of(msg))
    if "error" in answer:
        raise ApiError(500, f"simulate: {answer['error']}", code="internal_error")
    return await svc.compute.run(encode, {**answer["ok"], "scene": scene}, request.headers.get("accept"))


def _simulation_job(svc: Services, robot_id: str, body: bytes,
                    content_type: Optional[str]) -> tuple[dict[str, Any], dict[str, Any]]:
    """The job for a simulation worker, and the scene of its answer."""
    payload = decode(body, content_type, max_unpacked=8 * svc.settings.max_body_bytes)
    if isinstance(payload.get("torque"), str):  # in .npz the torque spec travels as a JSON string
        try:
            payload["torque"] = json.loads(payload["torque"])
        except json.JSONDecodeError:
            raise bad_input("torque: not a JSON object", "torque") from None
    req = validate(schemas.SimulateRequest, payload)
    s = svc.settings
    if req.sample_dt is not None and req.duration / req.sample_dt + 1 > s.max_samples:
        raise bad_input(f"sample_dt: {req.duration:g} s every {req.sample_dt:g} s is over the limit of "
                        f"{s.max_samples} samples (DYNAMICS_MAX_SAMPLES)", "sample_dt")
    if req.dt is not None and req.duration / req.dt > s.max_sim_steps:
        raise bad_input(f"dt: {req.duration:g} s in steps of {req.dt:g} s is over the limit of "
                        f"{s.max_sim_steps} steps (DYNAMICS_MAX_SIM_STEPS)", "dt")
    if req.sample_dt is None and req.dt is not None and req.integrator in ("euler", "rk4") \
            and req.duration / req.dt + 1 > s.max_samples:  # fixed-step runs sample every step by default
        raise bad_input(f"sample_dt: a sample at every step of {req.dt:g} s is over the limit of "
                        f"{s.max_samples} samples (DYNAMICS_MAX_SAMPLES); give a larger sample_dt", "sample_dt")
    # 404 and a bad locked set (422) here, before a process is involved; the worker builds the same model
    locked = locked_key(req.locked)
    entry = svc.compute.loaded(robot_id, locked)
    model = entry.model
    rec = svc.compute.record(robot_id)
    if req.q0.ndim != 1 or req.v0.ndim != 1:
        bad = "q0" if req.q0.ndim != 1 else "v0"
        raise bad_input(f"{bad}: expected one state, shape ({model.nq if bad == 'q0' else model.nv},), "
                        f"got {getattr(req, bad).shape}", bad)
    options = {k: getattr(req, k) for k in schemas.SIMULATE_OPTIONS}
    job = {"robot": {"id": rec.id, "urdf": rec.urdf, "floating_base": rec.floating_base}, "locked": locked,
           "q0": req.q0, "v0": req.v0, "duration": req.duration, "options": options,
           "torque": req.torque.model_dump() if req.torque is not None else None,
           "limits": {"max_samples": s.max_samples, "max_sim_steps": s.max_sim_steps}}
    return job, simulation_scene(entry, req.gravity)


def _openapi(app: FastAPI):
    def build() -> dict[str, Any]:
        if app.openapi_schema:
            return app.openapi_schema
        doc = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
        components = doc.setdefault("components", {}).setdefault("schemas", {})
        request_models = [m for m, _, _ in _DYNAMICS_ROUTES.values()] + [schemas.SimulateRequest,
                                                                          schemas.UploadRequest]
        for model in request_models:
            js = model.model_json_schema(ref_template="#/components/schemas/{model}")
            components.update(js.pop("$defs", {}))
            components[model.__name__] = js
        app.openapi_schema = doc
        return doc

    return build


def create_app(settings: Optional[Settings] = None) -> FastAPI:
    """The ASGI app. ``uvicorn service.app:create_app --factory`` or ``python -m service``."""
    settings = settings or Settings.from_env()

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        app.state.services = Services.start(settings)
        try:
            yield
        finally:
            app.state.services.close()

    app = FastAPI(title="dynamics", version=__version__, lifespan=lifespan,
                  description="Rigid-body dynamics of URDF robots: inverse and forward dynamics, mass matrix, "
                              "simulation. Errors are JSON {detail, code, field}.")
    install_handlers(app)
    app.include_router(router)
    app.add_middleware(ApiKeys, keys=settings.api_keys)
    app.openapi = _openapi(app)
    return app
