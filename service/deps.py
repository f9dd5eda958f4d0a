"""The dependency container: what every request of one server process shares, built once in the lifespan.

:meth:`Deps.start` builds the robot store, the model cache, the catalog, the compute pools, the simulation
workers and the warm-up (started in the background, so that the server answers at once); routes reach them with
``Depends(deps)``, and the request's time budget with ``Depends(budget)``. A test or another deployment passes
its own :class:`~service.settings.Settings` to :func:`service.app.create_app`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from starlette.requests import Request

from . import memory
from .catalog import Catalog
from .compute import OPERATIONS, Budget, Compute
from .errors import InvalidInput
from .constraints import OPERATIONS as CONSTRAINTS
from .derivatives import OPERATIONS as DERIVATIVES
from .kinematics import OPERATIONS as KINEMATICS
from .library import lib
from .models import Models
from .settings import Settings
from .sim.pool import SimPool
from .store import RobotStore
from .warmup import Stage, Warmup

#: where the warm-up's last duration is kept, in the store's directory (see service.warmup)
WARMUP_RECORD = ".warmup.json"


@dataclass
class Deps:
    settings: Settings
    store: RobotStore
    models: Models
    catalog: Catalog
    compute: Compute
    pool: Optional[SimPool]  # None: DYNAMICS_SIM_WORKERS=0, no simulation
    warmup: Warmup

    @classmethod
    def start(cls, settings: Settings) -> "Deps":
        memory.configure()  # large arrays freed go back to the system (the RSS returns to its baseline)
        store = RobotStore(settings.store_dir, settings.robots_dir)
        models = Models(store, settings.cache_size)
        pool = SimPool(settings.sim_workers) if settings.sim_workers > 0 else None  # workers compile at once
        warmup = Warmup(settings.store_dir / WARMUP_RECORD)
        compute = Compute(settings, models, pool, warmup, (OPERATIONS, KINEMATICS, CONSTRAINTS, DERIVATIVES))
        stages = [Stage("importing the library", lib), Stage("compiling dynamics kernels", compute.warm_kernels)]
        if pool is not None:
            plural = "es" if pool.size > 1 else ""
            stages.append(Stage(f"compiling simulation kernels in {pool.size} worker process{plural}", pool.wait_ready))
            stages.append(Stage("compiling the operational-space and computed-torque simulation kernels",
                                pool.wait_late))
        warmup.start(stages)
        return cls(settings, store, models, Catalog(settings, store, models), compute, pool, warmup)

    def close(self) -> None:
        self.compute.close()
        if self.pool is not None:
            self.pool.close()


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
