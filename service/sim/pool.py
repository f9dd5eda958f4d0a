"""A small pool of simulation worker processes that can be killed when a request runs out of time.

``concurrent.futures.ProcessPoolExecutor`` cannot stop one running task, so each worker here is a plain child
process (``python -m service.sim.worker``) talking over a socket pair with :mod:`multiprocessing.connection`.
A request takes an idle worker, sends its job and waits at most until its deadline; past it the worker is
killed (SIGKILL: the simulation holds no resource worth a clean exit) and a fresh one is started in its place,
so a runaway simulation never keeps a core busy after its answer (504) has left.

A new worker imports the library and runs one tiny simulation (numba compiles the integrator, or loads it
from its on-disk cache) before it says "ready"; only ready workers take jobs. So a request budget never kills
a compilation (which would then never finish): neither the warm-up's, nor one that a job starts (a kind of
simulation the warm-up did not compile, such as a PD controller with contact): the worker says so on its status
connection, and past the deadline the request is told to retry (503) while the worker finishes.
:attr:`SimPool.ready` is set once the first worker is ready: the end of the service's warm-up (see
:mod:`service.warmup`).

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
from typing import Any, Optional

log = logging.getLogger("service")

#: how long a new worker may take to import and compile before it is given up (and replaced)
READY_TIMEOUT = 600.0


class WorkerCrashed(RuntimeError):
    pass


class PoolTimeout(Exception):
    """The job ran past its deadline. ``args[1]``: False if its worker was compiling (its warm-up, or kernels
    the job needs), so that it was left to finish: the request may be retried; True if it was killed.
    ``args[2]`` where given: the seconds the compilation was announced to take."""


class PoolBusy(Exception):
    """No worker became free before the deadline."""


#: seconds a worker still warming up may go on with a job whose request gave up on it
WARM_GRACE = 600.0


class _Worker:
    """A worker process and its two connections: jobs (request, answer) and ``status`` (what the worker says of
    its own, unasked: its late warm-up's outcome, a compilation under way)."""

    #: the worker's command line, before its three arguments (FD STATUS_FD PARENT_PID)
    command = (sys.executable, "-m", "service.sim.worker")

    def __init__(self) -> None:
        parent, child = socket.socketpair()
        status_parent, status_child = socket.socketpair()
        try:
            self.proc = subprocess.Popen(
                [*self.command, str(child.fileno()), str(status_child.fileno()), str(os.getpid())],
                pass_fds=(child.fileno(), status_child.fileno()), stdin=subprocess.DEVNULL, close_fds=True,
            )
        finally:
            child.close()
            status_child.close()
        self.conn = Connection(parent.detach())
        self.status = Connection(status_parent.detach())
        self.jobs = 0
        self.started = time.monotonic()
        self.warm = False  # True once its whole warm-up (service.sim.warm) is over
        self.compiling = 0.0  # seconds the worker announced for a compilation during its current job, 0 if none

    def kill(self) -> None:
        for conn in (self.conn, self.status):
            try:
                conn.close()
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
        self.ready = threading.Event()  # set when the first worker is ready, and stays set
        self.late = threading.Event()   # set when the first worker's late warm-up ended (service.sim.warm)
        self.late_error: Optional[str] = None  # why it failed, None if it did not
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
        threading.Thread(target=self._await_status, args=(w,), daemon=True, name="sim-status").start()

    def _await_status(self, w: _Worker) -> None:
        """The worker's word on its late warm-up: ("late", None | "the error"), then ("contact", ...) and
        ("rest", ...); and at any time ("compiling", seconds): its job is compiling kernels."""
        while True:
            try:
                stage, error = w.status.recv()
            except (EOFError, OSError, ValueError, TypeError):
                return
            if stage == "compiling":
                w.compiling = float(error)
                continue
            if error:
                log.error("simulation worker %s: the %s warm-up failed: %s", w.proc.pid, stage, error)
            if stage == "late" and not self.late.is_set():
                self.late_error = error
                self.late.set()
            elif stage == "rest":
                w.warm = True

    def wait_late(self) -> None:
        """Block until a worker's late warm-up ended; a RuntimeError naming the failure if it failed."""
        self.late.wait()
        if self.late_error:
            raise RuntimeError(f"the operational-space and computed-torque kernels did not compile: "
                               f"{self.late_error}")

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
                raise PoolBusy("every simulation worker stayed busy until the deadline") from None
            if w.proc.poll() is None:
                break
            self._replace(w)  # died while idle (killed from outside, out of memory): take another
        if time.monotonic() > deadline:  # no time left for the job: the worker stays, idle
            self._idle.put(w)
            raise PoolTimeout("the deadline passed before the simulation could start")
        try:
            w.compiling = 0.0
            w.conn.send(job)
            if not w.conn.poll(max(0.0, deadline - time.monotonic())):
                if not w.warm or w.compiling:  # compiling (its warm-up's kernels, or the job's): killing it would
                    # lose them, and its replacement would start over (a short budget would never meet them
                    # compiled)
                    threading.Thread(target=self._finish, args=(w,), daemon=True, name="sim-finish").start()
                    raise PoolTimeout("the simulation's worker was compiling", False, w.compiling)
                self.killed += 1
                self._replace(w)
                raise PoolTimeout("the simulation ran past the deadline; its worker was stopped", w.warm)
            answer = w.conn.recv()
        except (EOFError, OSError) as e:
            code = w.proc.poll()
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

    def _finish(self, w: _Worker) -> None:
        """Let a compiling worker finish the job its request gave up on (its answer dropped), then take jobs
        again; one still busy after WARM_GRACE seconds is replaced after all."""
        try:
            if w.conn.poll(WARM_GRACE):
                w.conn.recv()
                w.jobs += 1
                self._idle.put(w)
                return
        except (EOFError, OSError):
            pass
        self.killed += 1
        self._replace(w)

    def close(self) -> None:
        self._closed = True
        with self._lock:
            workers = list(self._all)
            self._all.clear()
        for w in workers:
            w.kill()
        self._spawner.shutdown(wait=False, cancel_futures=True)
