"""The simulation worker process: ``python -m service.sim.worker FD PARENT_PID`` (started by
:mod:`service.sim.pool`; it exits when its server dies, :mod:`service.lifeline`).

It imports the library, says "ready", then reads :class:`~service.sim.job.Job` records from the connection on
file descriptor FD, runs ``dynamics.simulate`` inside the job's deadline (the C++ core checks it in its loop and
stops with ``DeadlineExceeded``, sent back as ``Outcome(deadline=True)``) and sends an
:class:`~service.sim.job.Outcome` back. Models are cached per worker by robot id and locked set, as in the
server. A library error becomes ``input_error`` (the server answers 422 naming the field); the process only ends
when its connection closes or the server kills it (a job still running shortly past its deadline).
The HTTP torque spec becomes the library's torque object through :mod:`service.torque`, as in the jobs.
"""

from __future__ import annotations

import sys
import time
import traceback
from multiprocessing.connection import Connection

import numpy as np

from .. import contact as contacts
from .. import torque as torques
from ..codec import finite_report
from ..errors import InvalidInput
from ..library import lib, parallel
from ..lifeline import bind_to_parent
from ..models import ModelCache, cached, load_model
from ..settings import configure_worker_logging
from .job import Job, Outcome


def simulate(model, job: Job) -> Outcome:
    """The trajectory of ``job`` and the seconds the library call took."""
    options = dict(job.options)
    torque = torques.build(job.torque)
    if torque is not None:
        options["torque"] = torque
    if job.contact is not None:
        options["contact"] = contacts.build(job.contact)
    # The step budget is the service's: a runaway adaptive run ends in a clear "max_steps: ..." 422 rather than
    # in the time budget's 504.
    started = time.perf_counter()
    with parallel().deadline(job.deadline):  # (time.monotonic's clock is the same in every process)
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
    except lib().DeadlineExceeded as e:  # the core stopped at the job's deadline: the server answers 504
        return Outcome(deadline=True, error=str(e))
    except InvalidInput as e:  # our own reading of the request (a URDF refused, an unknown torque type)
        return Outcome(input_error=e.detail)
    except ValueError as e:  # the library's InputError, URDFError, DynamicsError: the message names the field
        return Outcome(input_error=contacts.qualify(str(e)) if job.contact is not None else str(e))
    except Exception as e:  # noqa: BLE001 - reported to the server, which answers 500
        traceback.print_exc()
        return Outcome(error=f"{type(e).__name__}: {e}")


def main(fd: int, parent: int) -> None:
    bind_to_parent(parent)
    configure_worker_logging()
    conn = Connection(fd)
    cache = ModelCache(16)
    lib()  # before "ready": a job's time budget does not pay for the import
    try:
        conn.send("ready")
    except OSError:
        return
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        conn.send(handle(job, cache))


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]))
