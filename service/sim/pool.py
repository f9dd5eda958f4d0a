"""A small pool of simulation worker processes that can be killed when a request runs out of time.

``concurrent.futures.ProcessPoolExecutor`` cannot stop one running task, so each worker here is a plain child
process (``python -m service.sim.worker``) talking over a socket pair with :mod:`multiprocessing.connection`.
A request takes an idle worker, sends its job and waits at most until its deadline; past it the worker is
killed (SIGKILL: the simulation holds no resource worth a clean exit) and a fresh one is started in its place,
so a runaway simulation never keeps a core busy after its answer (504) has left.

A new worker imports the library before it says "ready"; only ready workers take jobs. Nothing is compiled at
run time (the library's C++ core is compiled when it is installed), so a worker is ready as soon as its import
is done, and every job past its deadline is killed alike. The C++ core also checks the deadline inside its
integration loop (``DeadlineExceeded``, answered as a 504 by the worker's own outcome), so the kill is the
backstop for a step that never reaches that check; the worker process itself also isolates the server from a
crash of the core (a 500 ``worker_crashed``, and a fresh worker) -- see docs/architecture.md for why simulations
still run in processes.

Plain ``subprocess`` rather than ``multiprocessing.Process``: no re-import of ``__main__``, no fork of a process
that runs an event loop and threads, and it works inside uvicorn's own worker processes.
"""

from __future__ import annotations

import logging
import os
import queue
import socket
import subprocess
import sys
import threading
import time
from multiprocessing.connection import Connection
from concurrent.futures import ThreadPoolExecutor
from typing import Any

log = logging.getLogger("service")

#: how long a new worker may take to import the library before it is given up (and replaced); the import takes
#: about a second, many more on a loaded machine
READY_TIMEOUT = 120.0


#: seconds past a job's deadline before its worker is killed: the core checks the deadline every 16 steps
#: (64 for a fixed step) and then answers by itself, which keeps the worker (a kill costs a new process and its
#: import of the library, about a second of a core)
KILL_GRACE = 0.25


class WorkerCrashed(RuntimeError):
    pass


class PoolTimeout(Exception):
    """The job ran past its deadline (its worker was killed), or the deadline passed before it could start."""


class PoolBusy(Exception):
    """No worker became free before the deadline."""


class _Worker:
    """A worker process and its connection (jobs there, answers back)."""

    #: the worker's command line, before its two arguments (FD PARENT_PID)
    command = (sys.executable, "-m", "service.sim.worker")

    def __init__(self) -> None:
        parent, child = socket.socketpair()
        try:
            self.proc = subprocess.Popen(
                [*self.command, str(child.fileno()), str(os.getpid())],
                pass_fds=(child.fileno(),), stdin=subprocess.DEVNULL, close_fds=True,
            )
        finally:
            child.close()
        self.conn = Connection(parent.detach())
        self.jobs = 0
        self.started = time.monotonic()

    def kill(self) -> None:
        try:
            self.conn.close()
        except OSError:
            pass
        if self.proc.poll() is None:
            self.proc.kill()
        # Reap in the background so that no zombie stays and the caller does not wait.
        threading.Thread(target=self.proc.wait, daemon=True).start()


class SimPool:
    """``run(job, deadline)`` blocks the calling thread until the answer or the deadline."""

    def __init__(self, size: int) -> None:
        self.size = max(1, size)
        self._idle: queue.Queue[_Worker] = queue.Queue()
        self._all: set[_Worker] = set()
        self._lock = threading.Lock()
        self._closed = False
        self.ready = threading.Event()  # set when the first worker is ready (has imported the library), stays set
        self.killed = 0
        # Every worker is started from this one thread, which lives as long as the pool: a worker's parent-death
        # signal (service.lifeline) fires when the thread that started it ends.
        self._spawner = ThreadPoolExecutor(max_workers=1, thread_name_prefix="sim-spawn")
        for _ in range(self.size):
            self._spawn()

    def _spawn(self) -> None:
        if not self._closed:
            self._spawner.submit(self._start)

    def _start(self) -> None:
        if self._closed:
            return
        w = _Worker()
        with self._lock:
            self._all.add(w)
        threading.Thread(target=self._await_ready, args=(w,), daemon=True, name="sim-ready").start()

    def _await_ready(self, w: _Worker) -> None:
        try:
            ok = w.conn.poll(READY_TIMEOUT) and w.conn.recv() == "ready"
        except (EOFError, OSError):
            ok = False
        if ok and not self._closed:
            log.debug("simulation worker %s ready after %.1f s", w.proc.pid, time.monotonic() - w.started)
            self.ready.set()
            self._idle.put(w)
            return
        if not self._closed:
            log.error("simulation worker %s did not start (exit code %s); starting another in 5 s",
                      w.proc.pid, w.proc.poll())
            self._retire(w)
            time.sleep(5.0)
            self._spawn()

    def _retire(self, w: _Worker) -> None:
        w.kill()
        with self._lock:
            self._all.discard(w)

    def _replace(self, w: _Worker) -> None:
        self._retire(w)
        self._spawn()

    def wait_ready(self, timeout: float | None = None) -> bool:
        """Wait until a worker was ready once (at most ``timeout`` seconds); whether one was."""
        return self.ready.wait(timeout)

    def pids(self) -> list[int]:
        with self._lock:
            return [w.proc.pid for w in self._all]

    def run(self, job: Any, deadline: float) -> Any:
        while True:
            try:
                w = self._idle.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise PoolBusy("every simulation worker stayed busy (or was still starting) until the deadline") from None
            if w.proc.poll() is None:
                break
            self._replace(w)  # died while idle (killed from outside, out of memory): take another
        if time.monotonic() > deadline:  # no time left for the job: the worker stays, idle
            self._idle.put(w)
            raise PoolTimeout("the deadline passed before the simulation could start")
        try:
            w.conn.send(job)
            # (the core stops at the job's deadline by itself and answers DeadlineExceeded; the grace lets that
            # answer arrive, and past it the worker is killed)
            if not w.conn.poll(max(0.0, deadline + KILL_GRACE - time.monotonic())):
                self.killed += 1
                self._replace(w)
                raise PoolTimeout("the simulation ran past the deadline; its worker was stopped")
            answer = w.conn.recv()
        except (EOFError, OSError) as e:
            try:  # (its connection closes a moment before the process is reaped: wait for the exit code)
                code = w.proc.wait(1.0)
            except subprocess.TimeoutExpired:
                code = None
            self._replace(w)
            raise WorkerCrashed(f"simulation worker exited (code {code}): {e}") from None
        except PoolTimeout:
            raise
        except BaseException:
            self._replace(w)
            raise
        w.jobs += 1
        self._idle.put(w)
        return answer

    def close(self) -> None:
        self._closed = True
        with self._lock:
            workers = list(self._all)
            self._all.clear()
        for w in workers:
            w.kill()
        self._spawner.shutdown(wait=False, cancel_futures=True)
