"""Where jobs run: a pool of job worker processes fed by one dispatcher thread, outside the request path.

The routes only write a job's inputs and its record (queued) and wake the dispatcher; they never wait on a job.
The dispatcher claims queued jobs (one transaction each, :meth:`JobDB.claim`) while a worker is free and hands
each to the process pool (:func:`service.jobs.runner.run_job`). Processes rather than threads of the server:
a job's Python work (chunking, stacking trajectories, writing .npz) then never holds the server's GIL, a job
that crashes its process (out of memory, a segfault) takes only itself down, and each worker keeps its
models between jobs. Inside a worker a part spreads over the local cores (the library's
threads) or, with ``DYNAMICS_RAY_ADDRESS``, over a Ray cluster; the pool's size (``DYNAMICS_JOB_WORKERS``,
default 1) is the number of jobs running at once on this server.

Crashes: this server process holds an flock on ``boots/<boot>.lock`` while it lives; the kernel drops it when
the process dies, however it dies. At start and every :data:`HOUSEKEEPING_SECONDS`, a running job whose boot's
lock can be taken has lost its server: it is queued again (it resumes after its last part) or, past
``DYNAMICS_JOB_ATTEMPTS`` starts, failed with the reason. A runner that finds its job no longer its own stops.
Housekeeping also removes finished jobs older than ``DYNAMICS_JOB_EXPIRY`` and temporary files a crash left.
"""

from __future__ import annotations

import fcntl
import logging
import multiprocessing
import os
import threading
import time
import uuid
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Optional

from ..lifeline import bind_to_parent
from ..settings import Settings
from .db import JobDB
from .files import JobFiles
from .runner import run_job

log = logging.getLogger("service.jobs")

HOUSEKEEPING_SECONDS = 5.0
#: a temporary file older than this was left by a crash (a part takes seconds to write)
STALE_TMP_SECONDS = 3600.0


class Executor:
    def __init__(self, files: JobFiles, db: JobDB, settings: Settings):
        self.files, self.db, self.settings = files, db, settings
        self.boot = uuid.uuid4().hex
        self._lock_fd = os.open(files.boot_lock(self.boot), os.O_RDWR | os.O_CREAT, 0o600)
        fcntl.flock(self._lock_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        self.pool: Optional[ProcessPoolExecutor] = None
        self.running: dict[str, Future] = {}
        self.wake = threading.Event()
        self.stopping = threading.Event()
        self.thread = threading.Thread(target=self._loop, name="jobs-dispatch", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def notify(self) -> None:
        self.wake.set()

    def close(self) -> None:
        """Stop dispatching, stop the workers and hand this server's running jobs back to the queue."""
        self.stopping.set()
        self.wake.set()
        if self.thread.is_alive():
            self.thread.join(5.0)
        if self.pool is not None:
            for process in list(getattr(self.pool, "_processes", {}).values()):  # no public way to stop a job
                process.terminate()
            # wait=True: the pool's manager thread sees its workers gone and releases its queues' semaphores
            # (left to the resource tracker otherwise, which warns of leaked semaphores at exit)
            self.pool.shutdown(wait=True, cancel_futures=True)
        n = self.db.release(self.boot)
        if n:
            log.info("jobs: %d running job(s) queued again for the next start", n)
        os.close(self._lock_fd)
        try:
            self.files.boot_lock(self.boot).unlink()
        except FileNotFoundError:
            pass

    # -- the dispatcher thread -------------------------------------------------------------------------------
    def _loop(self) -> None:
        last = 0.0
        while not self.stopping.is_set():
            try:
                if time.monotonic() - last > HOUSEKEEPING_SECONDS:
                    self.recover()
                    self.expire()
                    last = time.monotonic()
                self._reap()
                self._dispatch()
            except Exception:  # noqa: BLE001 - the dispatcher must outlive any one failure (a locked db)
                log.exception("jobs: dispatcher")
            self.wake.wait(1.0)
            self.wake.clear()

    def _dispatch(self) -> None:
        while len(self.running) < self.settings.job_workers and not self.stopping.is_set():
            job = self.db.claim(self.boot)
            if job is None:
                return
            if self.pool is None:
                # (started from this dispatcher thread, which lives as long as the server: the workers' parent-death
                # signal fires when it ends, service.lifeline)
                self.pool = ProcessPoolExecutor(max_workers=self.settings.job_workers,
                                                mp_context=multiprocessing.get_context("spawn"),
                                                initializer=bind_to_parent, initargs=(os.getpid(),))
            future = self.pool.submit(run_job, self.files, job.id, self.boot)
            future.add_done_callback(lambda _: self.wake.set())
            self.running[job.id] = future

    def _reap(self) -> None:
        for job_id, future in list(self.running.items()):
            if not future.done():
                continue
            del self.running[job_id]
            error = future.exception() if not future.cancelled() else None
            if isinstance(error, BrokenProcessPool):  # the worker died (killed, out of memory): a fresh pool
                if self.pool is not None:
                    self.pool.shutdown(wait=False, cancel_futures=True)
                self.pool = None
                status = self.db.retry_or_fail(job_id, "its worker process died", self.settings.job_attempts)
                if status == "failed":
                    self.files.remove(job_id)
                log.warning("jobs: %s lost its worker process; now %s", job_id, status)
            elif error is not None:
                self.db.fail(job_id, f"internal error: {type(error).__name__}: {error}", self.boot)
            else:
                self.db.fail(job_id, "internal error: the runner ended without a result", self.boot)  # if running

    # -- housekeeping ----------------------------------------------------------------------------------------
    def _alive(self, boot: Optional[str]) -> bool:
        """True while the server process of ``boot`` lives (it holds the lock file)."""
        if boot == self.boot:
            return True
        if not boot:
            return False
        try:
            fd = os.open(self.files.boot_lock(boot), os.O_RDWR)
        except FileNotFoundError:
            return False
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        finally:
            os.close(fd)
        return False

    def recover(self) -> None:
        """Jobs left running by a server process that is gone: queued again, or failed with the reason."""
        for job in self.db.with_status("running"):
            if not self._alive(job.boot):
                status = self.db.retry_or_fail(job.id, "the server running it stopped (crash or kill)",
                                               self.settings.job_attempts)
                if status == "failed":
                    self.files.remove(job.id)
                log.warning("jobs: %s was running on a server that is gone; now %s", job.id, status)
        for path in self.files.root.joinpath("boots").glob("*.lock"):
            if not self._alive(path.stem):
                path.unlink(missing_ok=True)
        if self.db.with_status("queued"):
            self.wake.set()

    def expire(self) -> None:
        """Finished jobs past their expiry, and temporary files a crash left and inputs files without a job (old
        enough that no writer of any server process can still be at them)."""
        for job_id in self.db.expired(time.time() - self.settings.job_expiry):
            self.files.remove(job_id)
            self.db.delete(job_id)
        orphans = [p for p in self.files.root.joinpath("inputs").glob("*.npz") if self.db.get(p.stem) is None]
        for stale in [*self.files.root.glob("**/.*.tmp"), *orphans]:  # (orphans: inputs of a submit that failed
            try:                                                       # before its record, by an older version)
                if stale.stat().st_mtime < time.time() - STALE_TMP_SECONDS:
                    stale.unlink()
            except FileNotFoundError:
                pass
