"""The simulation worker process: ``python -m service.sim.worker FD STATUS_FD PARENT_PID`` (started by
:mod:`service.sim.pool`; it exits when its server dies, :mod:`service.lifeline`).

It compiles the simulation kernels first (:mod:`service.sim.warm`), says "ready", compiles the operational-space
and computed-torque sources in a background thread and says on STATUS_FD how that went (and, whenever the library
announces that a simulation is compiling its kernels, ``("compiling", seconds)``: the pool then lets that job's
deadline pass without killing the compilation, which would otherwise never finish), then reads
:class:`~service.sim.job.Job` records from the connection on file descriptor FD, runs ``dynamics.simulate``
and sends an :class:`~service.sim.job.Outcome` back. Models are cached per worker by robot id and locked set, as
in the server. A library error becomes ``input_error`` (the server answers 422 naming the field); the process
only ends when its connection closes or the server kills it.
The HTTP torque spec becomes the library's torque object through :mod:`service.torque`, as in the jobs.
"""

from __future__ import annotations

import logging
import sys
import threading
import time
import traceback
from multiprocessing.connection import Connection
from typing import Optional

import numpy as np

from .. import contact as contacts
from .. import torque as torques
from ..codec import finite_report
from ..errors import InvalidInput
from ..library import lib
from ..lifeline import bind_to_parent
from ..models import ModelCache, cached, load_model
from ..settings import configure_worker_logging
from . import warm
from .job import Job, Outcome


def simulate(model, job: Job) -> Outcome:
    """The trajectory of ``job`` and the seconds the library call took, or (a torque source still compiling past
    the job's deadline) the Outcome that says so."""
    options = dict(job.options)
    torque = torques.build(job.torque)
    later = warm.LATER
    if job.torque is not None and job.torque["type"] in later.kinds and not later.done.is_set():
        lib().torques.make_source(model, torque)  # a bad spec is answered (422) at once, not after the wait
        if not later.wait(job.deadline):
            return later.unavailable()
    if torque is not None:
        options["torque"] = torque
    if job.contact is not None:
        options["contact"] = contacts.build(job.contact)  # (a bad declaration: a 422 at once, before any wait)
        if not later.wait_contact(job.deadline):
            return later.contact_unavailable()
    # The step budget is the service's: a runaway adaptive run ends in a clear "max_steps: ..." 422 rather than
    # in the time budget's 504.
    started = time.perf_counter()
    traj = lib().simulate(model, job.q0, job.v0, job.duration, max_steps=job.max_steps, **options)
    seconds = time.perf_counter() - started
    out = {name: np.asarray(getattr(traj, name)) for name in ("t", "q", "v", "tau")}
    if traj.lam is not None:
        out["lambda"] = np.asarray(traj.lam)
    out.update(contacts.samples(getattr(traj, "contacts", None)))
    if traj.sensitivities is not None:
        out["sensitivities"] = np.asarray(traj.sensitivities)
    out["report"] = finite_report(dict(traj.report or {}))
    return Outcome(trajectory=out, seconds=seconds)


def handle(job: Job, cache: ModelCache) -> Outcome:
    try:
        model = cached(cache, job.robot_id, job.locked, lambda: load_model(job.urdf, job.floating_base))
        return simulate(model, job)
    except InvalidInput as e:  # our own reading of the request (a URDF refused, an unknown torque type)
        return Outcome(input_error=e.detail)
    except ValueError as e:  # the library's InputError, URDFError, DynamicsError: the message names the field
        return Outcome(input_error=contacts.qualify(str(e)) if job.contact is not None else str(e))
    except Exception as e:  # noqa: BLE001 - reported to the server, which answers 500
        traceback.print_exc()
        return Outcome(error=f"{type(e).__name__}: {e}")


class _Announcements(logging.Handler):
    """Passes the library's "compiling the simulation kernels ..." announcements (log records with a
    ``compile_seconds``) to the pool as ``("compiling", seconds)``."""

    def __init__(self, report) -> None:
        super().__init__(logging.WARNING)
        self.report = report

    def emit(self, record: logging.LogRecord) -> None:
        seconds = getattr(record, "compile_seconds", None)
        if seconds is not None:
            self.report("compiling", float(seconds))


def main(fd: int, status_fd: int, parent: int) -> None:
    bind_to_parent(parent)
    configure_worker_logging()
    conn, status = Connection(fd), Connection(status_fd)
    cache = ModelCache(16)
    # before "ready": no request's time budget ever runs into a compilation; a failure here is the first job's
    # to report (the problem type it needs did not compile)
    warm.attempt(warm.warm_up)
    try:
        conn.send("ready")
    except OSError:
        return

    lock = threading.Lock()  # the late warm-up's thread and the library's announcing timer both report

    def report(stage: str, error: Optional[str]) -> None:
        try:
            with lock:
                status.send((stage, error))
        except OSError:
            pass

    logging.getLogger("dynamics.simulation").addHandler(_Announcements(report))
    warm.LATER.start(report)
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        conn.send(handle(job, cache))


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]))
