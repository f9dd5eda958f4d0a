"""A stand-in for :mod:`service.sim.worker` that speaks its protocol without the library
(tests/test_sim_pool.py): "ready", its late warm-up's three stages on the status connection, then per job
``(seconds, compiles)``: ``("compiling", 40.0)`` on the status connection if it compiles, ``seconds`` of sleep,
and the answer ``("done", seconds, pid)``."""

import os
import sys
import time
from multiprocessing.connection import Connection


def main(fd: int, status_fd: int) -> None:
    conn, status = Connection(fd), Connection(status_fd)
    conn.send("ready")
    for stage in ("late", "contact", "rest"):
        status.send((stage, None))
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        seconds, compiles = job
        if compiles:
            status.send(("compiling", 40.0))
        time.sleep(seconds)
        conn.send(("done", seconds, os.getpid()))


if __name__ == "__main__":
    main(int(sys.argv[1]), int(sys.argv[2]))
