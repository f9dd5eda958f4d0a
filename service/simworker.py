"""The simulation worker process: ``python -m service.simworker FD`` (started by :mod:`service.simpool`).

It reads jobs from the connection on file descriptor FD, runs ``dynamics.simulate`` and sends the trajectory
back. Models are cached per worker by robot id and locked set, as in the server process. Any library error
becomes an ``input_error`` answer (the server turns it into a 422 naming the field); the process only ends when
its connection closes or the server kills it.
"""

from __future__ import annotations

import sys
import traceback
from multiprocessing.connection import Connection
from typing import Any


def handle(job: dict[str, Any], cache) -> dict[str, Any]:
    from .simjob import run_simulation
    from .store import RobotRecord
    from .compute import load_model, reduce_model

    robot = job["robot"]
    locked = job.get("locked", ())  # canonical locked set (service.compute.locked_key), () for none
    record = RobotRecord(id=robot["id"], name=robot["id"], urdf=robot["urdf"],
                         floating_base=robot["floating_base"], bundled=False)
    try:
        model = cache.get_or_load((robot["id"], ()), lambda: load_model(record))
        if locked:
            full = model
            model = cache.get_or_load((robot["id"], locked), lambda: reduce_model(full, locked))
        return {"ok": run_simulation(model, job)}
    except ValueError as e:  # InputError, URDFError, DynamicsError and our own checks
        return {"input_error": str(e)}
    except Exception as e:  # noqa: BLE001 - reported to the server, which logs it
        return {"error": f"{type(e).__name__}: {e}", "traceback": traceback.format_exc(limit=8)}


_WARMUP_URDF = b"""<robot name="warmup"><link name="base"/>
  <link name="arm"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="continuous"><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/></joint>
</robot>"""


def warmup() -> None:
    """One tiny simulation per torque kind: numba compiles the integration loop (or loads it from its cache)."""
    import numpy as np

    import dynamics
    from .simjob import build_torque, simulate_function

    simulate = simulate_function()
    if simulate is None:
        return
    model = dynamics.load_urdf(_WARMUP_URDF)
    for spec in ({"type": "zero"}, {"type": "pd", "q_target": np.zeros(1), "kp": 1.0, "kd": 1.0}):
        simulate(model, np.array([0.1]), np.zeros(1), 0.01, torque=build_torque(model, spec))


def main(fd: int) -> None:
    from .store import ModelCache

    conn = Connection(fd)
    cache = ModelCache(16)
    for attempt in range(2):  # before "ready": no request's time budget ever runs into a compilation
        try:
            warmup()
            break
        except Exception:  # noqa: BLE001 - once more (e.g. a cache file being written by another process),
            traceback.print_exc()  # then the first job reports the real problem
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
    main(int(sys.argv[1]))
