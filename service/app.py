"""The FastAPI application, assembled: settings, logging, dependencies, middleware, routes, errors, OpenAPI.

``uvicorn service.app:create_app --factory`` or ``python -m service``. Nothing here computes: the routes are in
:mod:`service.routes`, what they share in :mod:`service.deps` (built in the lifespan), the mapping of errors to
HTTP answers in :mod:`service.errors`. The app imports no numeric library, so that it answers at once; the
library is imported in the background at start (:mod:`service.deps`, :mod:`service.library`).
"""

from __future__ import annotations

from contextlib import asynccontextmanager
from typing import Any, Optional

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from fastapi_offline import FastAPIOffline

from . import __version__, errors, schemas
from .auth import ApiKeys
from .compute import OPERATIONS
from .constraints import OPERATIONS as CONSTRAINTS
from .deps import Deps
from .derivatives import OPERATIONS as DERIVATIVES
from .jobs.manager import Jobs
from .kinematics import OPERATIONS as KINEMATICS
from .protocol import Head, Options, SecurityHeaders
from .routes import (constraints, derivatives, dynamics, health, inspect, jobs, kinematics, robots, sessions,
                     simulate)
from .sessions import Sessions
from .settings import Settings, configure_logging

DESCRIPTION = ("Rigid-body dynamics of URDF robots: inverse and forward dynamics, mass matrix, Coriolis matrix, "
               "energies, kinematics and task space (frames, Jacobians, centre of mass, M^-1, operational-space "
               "inertia, inverse kinematics), analytical derivatives of inverse and forward dynamics, simulation. Every array argument takes one state or a batch; bodies "
               "and answers are JSON or .npz (application/x-npz). Errors are JSON {detail, code, field}.")


def _openapi(app: FastAPI):
    """The routes read their bodies themselves; their request schemas are added to the document here."""

    def build() -> dict[str, Any]:
        if app.openapi_schema:
            return app.openapi_schema
        doc = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
        components = doc.setdefault("components", {}).setdefault("schemas", {})
        requests = [op.endpoint.request for table in (OPERATIONS, KINEMATICS, CONSTRAINTS, DERIVATIVES) for op in table.values()]
        requests += [schemas.SimulateRequest, schemas.UploadRequest, schemas.JobRequest]
        for model in requests:
            js = model.model_json_schema(ref_template="#/components/schemas/{model}")
            components.update(js.pop("$defs", {}))
            components[model.__name__] = js
        app.openapi_schema = doc
        return doc

    return build


def create_app(settings: Optional[Settings] = None) -> FastAPI:
    """The ASGI app; ``settings`` default to the environment's (:meth:`Settings.from_env`)."""
    settings = settings or Settings.from_env()
    configure_logging(settings.log_level)

    @asynccontextmanager
    async def lifespan(app: FastAPI):
        app.state.deps = Deps.start(settings)
        app.state.jobs = Jobs.start(settings, app.state.deps.models, app.state.deps.catalog.resolve)
        app.state.sessions = Sessions(settings)  # the WebSocket sessions of this process (service.sessions)
        try:
            yield
        finally:
            app.state.sessions.close()
            app.state.jobs.close()
            app.state.deps.close()

    # /docs (Swagger UI) and /redoc load their scripts and styles from the installed fastapi-offline package, under
    # /static-offline-docs: they work without internet access (FastAPI's own pages load them from a CDN)
    app = FastAPIOffline(title="dynamics", version=__version__, lifespan=lifespan, description=DESCRIPTION)
    errors.install(app)
    for module in (health, robots, dynamics, kinematics, constraints, derivatives, simulate, jobs, sessions):
        app.include_router(module.router)
    from .routes import guide; guide.mount(app)  # the documentation site at /guide, when it has been built
    app.include_router(inspect.router)  # last: no API request is matched against the page's paths
    app.add_middleware(ApiKeys, keys=settings.api_keys, open_paths=health.OPEN_PATHS, open_prefix=inspect.PREFIX,
                       closed_paths=(inspect.TRAJECTORY,))
    app.add_middleware(Head)  # (GET's answer without its body, on every path a GET answers)
    app.add_middleware(Options, routes=app.router.routes)  # (before the key check: Allow tells no secret)
    app.add_middleware(errors.RequestIds)  # outermost but one, so that it sees every exception
    app.add_middleware(SecurityHeaders)  # outermost: its headers on every answer, RequestIds' 500s included
    app.openapi = _openapi(app)
    return app
