"""What travels between the server and a simulation worker: a :class:`Job` there, an :class:`Outcome` back.

Both are plain records of arrays, numbers and dicts (cheap to pickle; nothing callable crosses the process
boundary). The server builds the job (:func:`build_job`, which applies the service's own limits); the worker
turns it into a ``dynamics.simulate`` call (:mod:`service.sim.worker`), where the library checks every argument.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from ..errors import InvalidInput
from ..schemas import SIMULATE_OPTIONS, SimulateRequest
from ..settings import Settings
from ..store import RobotRecord


@dataclass(frozen=True)
class Job:
    robot_id: str
    urdf: str
    floating_base: bool
    locked: tuple                 # canonical locked set (service.models.locked_key), () for none
    q0: np.ndarray
    v0: np.ndarray
    duration: float
    options: dict[str, Any]       # keyword arguments of dynamics.simulate that the request gave
    torque: Optional[dict[str, Any]]  # the HTTP torque spec ({"type": "pd", ...}), None for no torque
    max_steps: int                # the service's step budget, whatever the request says
    deadline: float = math.inf    # the request's deadline on time.monotonic's clock (the same in every process)
    contact: Optional[dict[str, Any]] = None  # the HTTP contact spec (service.contact), None for no contact


@dataclass(frozen=True)
class Outcome:
    """A worker's answer: the trajectory (t, q, v, tau, report) and the seconds its library call took, or the
    library's input error, or a failure, or ``deadline``: the core stopped the run at the job's deadline (its
    message in ``error``)."""
    trajectory: Optional[dict[str, Any]] = None
    input_error: Optional[str] = None
    error: Optional[str] = None
    deadline: bool = False
    seconds: float = 0.0  # the library call's wall time in the worker (the answer's Server-Timing)


def samples(duration: float, sample_dt: Optional[float], dt: Optional[float], integrator: Optional[str]) -> int:
    """How many samples ``dynamics.simulate`` returns at most, its rule in the one place the service needs it:
    every ``sample_dt``, else every step of a fixed-step method (euler, rk4), else 1001. (Capped at 1e15 + 2: a
    count for limits and estimates, never an allocation.)"""
    spacing = sample_dt if sample_dt is not None else dt if integrator in ("euler", "rk4") else None
    if spacing is None:
        return 1001
    return int(min(duration / spacing, 1e15)) + 2


def build_job(record: RobotRecord, locked: tuple, req: SimulateRequest, settings: Settings) -> Job:
    """The job of a simulation request, within the service's limits of steps and samples."""
    s = settings
    if req.dt is not None and req.duration / req.dt > s.max_sim_steps:
        raise InvalidInput(f"dt: {req.duration:g} s in steps of {req.dt:g} s is over the limit of "
                           f"{s.max_sim_steps} steps (DYNAMICS_MAX_SIM_STEPS)", "dt")
    if samples(req.duration, req.sample_dt, req.dt, req.integrator) - 1 > s.max_samples:
        if req.sample_dt is not None:
            raise InvalidInput(f"sample_dt: {req.duration:g} s every {req.sample_dt:g} s is over the limit of "
                               f"{s.max_samples} samples (DYNAMICS_MAX_SAMPLES)", "sample_dt")
        # fixed-step runs sample every step by default
        raise InvalidInput(f"sample_dt: a sample at every step of {req.dt:g} s is over the limit of "
                           f"{s.max_samples} samples (DYNAMICS_MAX_SAMPLES); give a larger sample_dt", "sample_dt")
    options = {k: getattr(req, k) for k in SIMULATE_OPTIONS if getattr(req, k) is not None}
    return Job(robot_id=record.id, urdf=record.urdf, floating_base=record.floating_base, locked=locked,
               q0=req.q0, v0=req.v0, duration=req.duration, options=options,
               torque=req.torque.model_dump() if req.torque is not None else None, max_steps=s.max_sim_steps,
               contact=req.contact.model_dump(exclude_none=True) if req.contact is not None else None)
