"""A stand-in for :mod:`service.sim.worker` that speaks its protocol without the library
(tests/test_sim_pool.py): "ready", then per job ``seconds`` (a float): that much sleep, and the answer
``("done", seconds, pid)``; the job ``"crash"`` ends the process without an answer."""

import os
import sys
import time
from multiprocessing.connection import Connection


def main(fd: int) -> None:
    conn = Connection(fd)
    conn.send("ready")
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        if job == "crash":
            os._exit(3)
        time.sleep(job)
        conn.send(("done", job, os.getpid()))


if __name__ == "__main__":
    main(int(sys.argv[1]))
