"""The simulation worker process: ``python -m service.simworker FD`` (started by :mod:`service.simpool`).

It reads jobs from the connection on file descriptor FD, runs ``dynamics.simulate`` and sends the trajectory
back. Models are cached per worker by robot id, as in the server process. Any library error becomes an
``input_error`` answer (the server turns it into a 422 naming the field); the process only ends when its
connection closes or the server kills it.
"""

from __future__ import annotations

import sys
import traceback
from multiprocessing.connection import Connection
from typing import Any


def handle(job: dict[str, Any], cache) -> dict[str, Any]:
    from .simjob import run_simulation
    from .store import RobotRecord
    from .compute import load_model

    robot = job["robot"]
    key = (robot["id"], ())
    record = RobotRecord(id=robot["id"], name=robot["id"], urdf=robot["urdf"],
                         floating_base=robot["floating_base"], bundled=False)
    try:
        model = cache.get_or_load(key, lambda: load_model(record))
        return {"ok": run_simulation(model, job)}
    except ValueError as e:  # InputError, URDFError, DynamicsError and our own checks
        return {"input_error": str(e)}
    except Exception as e:  # noqa: BLE001 - reported to the server, which logs it
        return {"error": f"{type(e).__name__}: {e}", "traceback": traceback.format_exc(limit=8)}


def main(fd: int) -> None:
    from .store import ModelCache

    conn = Connection(fd)
    cache = ModelCache(16)
    try:
        import dynamics  # noqa: F401 - import (and load numba's cache) while idle, not on the first job
    except Exception:  # pragma: no cover - the first job reports it
        pass
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        conn.send(handle(job, cache))


if __name__ == "__main__":
    main(int(sys.argv[1]))
