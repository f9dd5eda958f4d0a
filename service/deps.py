"""The dependency container: what every request of one server process shares, built once in the lifespan.

:meth:`Deps.start` builds the robot store, the model cache, the catalog, the compute pools and the simulation
workers, and starts importing the library in the background (so that the server answers at once); routes reach
them with
``Depends(deps)``, and the request's time budget with ``Depends(budget)``. A test or another deployment passes
its own :class:`~service.settings.Settings` to :func:`service.app.create_app`.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from typing import Optional

from starlette.requests import Request

from . import memory
from .catalog import Catalog
from .compute import Budget, Compute
from .errors import InvalidInput
from .library import lib
from .models import Models
from .settings import Settings
from .sim.pool import SimPool
from .store import RobotStore

log = logging.getLogger("service")


@dataclass
class Deps:
    settings: Settings
    store: RobotStore
    models: Models
    catalog: Catalog
    compute: Compute
    pool: Optional[SimPool]  # None: DYNAMICS_SIM_WORKERS=0, no simulation

    @classmethod
    def start(cls, settings: Settings) -> "Deps":
        memory.configure()  # large arrays freed go back to the system (the RSS returns to its baseline)
        store = RobotStore(settings.store_dir, settings.robots_dir)
        models = Models(store, settings.cache_size)
        pool = SimPool(settings.sim_workers) if settings.sim_workers > 0 else None  # workers import the library
        compute = Compute(settings, models, pool)
        # The library's import (about a second, see service.library) in the background, so that the first request
        # does not pay it; one that comes earlier waits for it in its worker thread, never on the event loop.
        threading.Thread(target=_import_library, daemon=True, name="import-dynamics").start()
        return cls(settings, store, models, Catalog(settings, store, models), compute, pool)

    def close(self) -> None:
        self.compute.close()
        if self.pool is not None:
            self.pool.close()


def _import_library() -> None:
    started = time.monotonic()
    try:
        lib()
    except Exception:  # noqa: BLE001 - logged; every request that needs the library raises it again (a 500)
        log.exception("importing the dynamics library failed")
        return
    log.info("the dynamics library was imported in %.2f s", time.monotonic() - started)


def deps(request: Request) -> Deps:
    return request.app.state.deps


def budget(request: Request) -> Budget:
    """The request's wall-time budget: the server's, or less if the caller asks (``X-Time-Budget: seconds``)."""
    seconds = request.app.state.deps.settings.time_budget
    asked = request.headers.get("x-time-budget")
    if asked is not None:
        try:
            value = float(asked)
        except ValueError:
            value = float("nan")
        if not value > 0:
            raise InvalidInput(f"X-Time-Budget: expected a positive number of seconds, got {asked!r}", "X-Time-Budget")
        seconds = min(seconds, value)
    return Budget.starting_now(seconds)
