"""The job records: one SQLite database (stdlib ``sqlite3``, WAL mode) in the store directory, ``jobs/jobs.db``.

Why SQLite: an embedded, transactional database that every Python has, safe between threads and processes
(the server's threads write submissions, the job worker processes write progress), that survives a SIGKILL at
any instant (a commit is in the write-ahead log or it is not) and needs no server of its own. WAL lets readers
(status polls) go on while a writer commits; ``synchronous=FULL`` makes a commit durable before the 202 is sent.

A job moves ``queued -> running -> done | failed``, or to ``cancelled`` from either of the first two. Who runs a
job is the ``boot`` of a server process (:mod:`service.jobs.executor`), which holds a lock file for its life:
when that lock can be taken, the process is gone, and its running jobs are handed back (:meth:`JobDB.recover`).
Arrays never go into the database: inputs, the parts done so far and the result are files beside it
(:mod:`service.jobs.runner`); the database holds what they are and where.
"""

from __future__ import annotations

import json
import logging
import os
import sqlite3
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

log = logging.getLogger("service.jobs")

STATES = ("queued", "running", "done", "failed", "cancelled")
ACTIVE = ("queued", "running")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY,
    owner TEXT,                 -- service.store.owner_tag of the key that made it ('' without keys)
    robot TEXT NOT NULL,
    kind TEXT NOT NULL,
    spec TEXT NOT NULL,         -- JSON: options and the non-array parts of the inputs
    status TEXT NOT NULL,
    done INTEGER NOT NULL DEFAULT 0,
    total INTEGER NOT NULL,
    created REAL NOT NULL,
    started REAL,
    finished REAL,
    error TEXT,
    attempts INTEGER NOT NULL DEFAULT 0,
    boot TEXT,                  -- the server process running it (NULL unless running)
    input_bytes INTEGER NOT NULL DEFAULT 0,
    result_bytes INTEGER NOT NULL DEFAULT 0,
    compute_seconds REAL NOT NULL DEFAULT 0
);
CREATE INDEX IF NOT EXISTS jobs_status ON jobs (status, created);
CREATE INDEX IF NOT EXISTS jobs_owner ON jobs (owner, status);
"""


#: the files SQLite keeps beside the database (write-ahead log, shared-memory index)
SIDE_FILES = ("-wal", "-shm")


def private(path: Path) -> None:
    """The database and its side files readable and writable by the server's user only (0600), as the robot
    store's files and the job arrays are (they hold job specs, owners' key hashes and errors).

    The database is created here with mode 0600 before SQLite opens it: SQLite creates the WAL and SHM files with
    the database's own mode, so they follow. Files an older version left 0644 are tightened."""
    os.close(os.open(path, os.O_RDWR | os.O_CREAT, 0o600))
    for p in (path, *(path.with_name(path.name + suffix) for suffix in SIDE_FILES)):
        try:
            if p.stat().st_mode & 0o077:
                os.chmod(p, 0o600)
        except FileNotFoundError:
            pass
        except PermissionError:  # another user's file (a volume shared on purpose): said, not fatal
            log.warning("jobs: %s is readable by other users and not ours to change (chmod 600 it)", p)


@dataclass(frozen=True)
class JobRecord:
    id: str
    owner: str
    robot: str
    kind: str
    spec: dict[str, Any]
    status: str
    done: int
    total: int
    created: float
    started: Optional[float]
    finished: Optional[float]
    error: Optional[str]
    attempts: int
    boot: Optional[str]
    input_bytes: int
    result_bytes: int
    compute_seconds: float

    @classmethod
    def from_row(cls, row: sqlite3.Row) -> "JobRecord":
        d = dict(row)
        d["spec"] = json.loads(d["spec"])
        return cls(**d)


class JobDB:
    """The jobs table; one connection per thread (sqlite3 connections are not shared between threads)."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        private(self.path)
        self._local = threading.local()
        self._conn().executescript(_SCHEMA)  # (executescript commits by itself)

    def _conn(self) -> sqlite3.Connection:
        conn = getattr(self._local, "conn", None)
        if conn is None:
            conn = sqlite3.connect(self.path, timeout=30.0, isolation_level=None, check_same_thread=True)
            conn.row_factory = sqlite3.Row
            conn.execute("PRAGMA journal_mode=WAL")
            conn.execute("PRAGMA synchronous=FULL")
            self._local.conn = conn
        return conn

    class _Tx:
        def __init__(self, conn: sqlite3.Connection):
            self.conn = conn

        def __enter__(self) -> sqlite3.Connection:
            self.conn.execute("BEGIN IMMEDIATE")  # take the write lock now: no upgrade deadlock between writers
            return self.conn

        def __exit__(self, kind, exc, tb) -> None:
            self.conn.execute("COMMIT" if kind is None else "ROLLBACK")

    def _tx(self) -> "_Tx":
        return self._Tx(self._conn())

    # -- reading ---------------------------------------------------------------------------------------------
    def get(self, job_id: str) -> Optional[JobRecord]:
        row = self._conn().execute("SELECT * FROM jobs WHERE id = ?", (job_id,)).fetchone()
        return JobRecord.from_row(row) if row else None

    def owns(self, job_id: str, boot: str) -> bool:
        """True while ``job_id`` is running under ``boot`` (not cancelled, deleted or handed on)."""
        return self._conn().execute("SELECT 1 FROM jobs WHERE id = ? AND status = 'running' AND boot = ?",
                                    (job_id, boot)).fetchone() is not None

    def active_count(self, owner: str) -> int:
        return self._conn().execute(f"SELECT count(*) FROM jobs WHERE owner = ? AND status IN {ACTIVE}",
                                    (owner,)).fetchone()[0]

    def bytes_used(self, owner: Optional[str] = None) -> int:
        """Disk held by job inputs and results: one key's (``owner``) or everyone's."""
        where, args = ("WHERE owner = ?", (owner,)) if owner is not None else ("", ())
        return self._conn().execute(f"SELECT coalesce(sum(input_bytes + result_bytes), 0) FROM jobs {where}",
                                    args).fetchone()[0]

    def with_status(self, *states: str) -> list[JobRecord]:
        marks = ",".join("?" * len(states))
        rows = self._conn().execute(f"SELECT * FROM jobs WHERE status IN ({marks}) ORDER BY created", states)
        return [JobRecord.from_row(r) for r in rows]

    def of_owner(self, owner: str) -> list[JobRecord]:
        rows = self._conn().execute("SELECT * FROM jobs WHERE owner = ? ORDER BY created", (owner,))
        return [JobRecord.from_row(r) for r in rows]

    def expired(self, before: float) -> list[str]:
        return [r[0] for r in self._conn().execute(
            f"SELECT id FROM jobs WHERE status NOT IN {ACTIVE} AND finished < ?", (before,))]

    # -- writing ---------------------------------------------------------------------------------------------
    def create(self, job_id: str, owner: str, robot: str, kind: str, spec: dict[str, Any], total: int,
               input_bytes: int, max_active: Optional[int] = None) -> bool:
        """Queue a job; False (nothing written) when ``owner`` already has ``max_active`` jobs queued or running:
        counted in the insert's transaction, so that two submissions at once cannot both take the last place."""
        with self._tx() as c:
            if max_active is not None and c.execute(f"SELECT count(*) FROM jobs WHERE owner = ? AND status IN "
                                                    f"{ACTIVE}", (owner,)).fetchone()[0] >= max_active:
                return False
            c.execute("INSERT INTO jobs (id, owner, robot, kind, spec, status, total, created, input_bytes) "
                      "VALUES (?, ?, ?, ?, ?, 'queued', ?, ?, ?)",
                      (job_id, owner, robot, kind, json.dumps(spec), total, time.time(), input_bytes))
        return True

    def claim(self, boot: str) -> Optional[JobRecord]:
        """The oldest queued job, now running under ``boot`` (one transaction: two servers never take one job)."""
        with self._tx() as c:
            row = c.execute("SELECT id FROM jobs WHERE status = 'queued' ORDER BY created LIMIT 1").fetchone()
            if row is None:
                return None
            c.execute("UPDATE jobs SET status = 'running', boot = ?, attempts = attempts + 1, "
                      "started = coalesce(started, ?) WHERE id = ?", (boot, time.time(), row[0]))
        return self.get(row[0])

    def progress(self, job_id: str, boot: str, done: int, seconds: float) -> bool:
        """Record progress of a running job; False when it is no longer this runner's (cancelled, deleted,
        handed to another server): the runner then stops."""
        with self._tx() as c:
            n = c.execute("UPDATE jobs SET done = ?, compute_seconds = ? WHERE id = ? AND status = 'running' "
                          "AND boot = ?", (done, seconds, job_id, boot)).rowcount
        return n == 1

    def finish(self, job_id: str, boot: str, result_bytes: int, seconds: float) -> bool:
        with self._tx() as c:
            n = c.execute("UPDATE jobs SET status = 'done', done = total, result_bytes = ?, compute_seconds = ?, "
                          "input_bytes = 0, finished = ?, boot = NULL WHERE id = ? AND status = 'running' AND boot = ?",
                          (result_bytes, seconds, time.time(), job_id, boot)).rowcount
        return n == 1

    def fail(self, job_id: str, reason: str, boot: Optional[str] = None) -> None:
        """Failed for good, with the reason (only if still active, and still ``boot``'s when given)."""
        with self._tx() as c:
            c.execute(f"UPDATE jobs SET status = 'failed', error = ?, finished = ?, boot = NULL, input_bytes = 0 "
                      f"WHERE id = ? AND status IN {ACTIVE} AND (? IS NULL OR boot = ?)",
                      (reason, time.time(), job_id, boot, boot))

    def retry_or_fail(self, job_id: str, reason: str, max_attempts: int) -> str:
        """A running job whose runner is gone: queued again (it resumes after its last part) while it has
        attempts left, else failed with ``reason``. Returns the new status."""
        with self._tx() as c:
            row = c.execute("SELECT attempts FROM jobs WHERE id = ? AND status = 'running'", (job_id,)).fetchone()
            if row is None:
                return ""
            if row[0] < max_attempts:
                c.execute("UPDATE jobs SET status = 'queued', boot = NULL, error = ? WHERE id = ?",
                          (f"restarted: {reason}", job_id))
                return "queued"
            c.execute("UPDATE jobs SET status = 'failed', boot = NULL, finished = ?, error = ?, input_bytes = 0 "
                      "WHERE id = ?",
                      (time.time(), f"{reason} (attempt {row[0]} of {max_attempts}; not retried)", job_id))
            return "failed"

    def release(self, boot: str) -> int:
        """A server stopping cleanly hands its running jobs back to the queue (no attempt spent)."""
        with self._tx() as c:
            return c.execute("UPDATE jobs SET status = 'queued', boot = NULL, attempts = max(0, attempts - 1) "
                             "WHERE status = 'running' AND boot = ?", (boot,)).rowcount

    def cancel(self, job_id: str) -> bool:
        """A queued or running job becomes cancelled (its runner sees it at its next part); True if it was."""
        with self._tx() as c:
            return c.execute(f"UPDATE jobs SET status = 'cancelled', finished = ?, boot = NULL, input_bytes = 0, "
                             f"result_bytes = 0 WHERE id = ? AND status IN {ACTIVE}",
                             (time.time(), job_id)).rowcount == 1

    def delete(self, job_id: str) -> None:
        with self._tx() as c:
            c.execute("DELETE FROM jobs WHERE id = ?", (job_id,))

    def close(self) -> None:
        conn = getattr(self._local, "conn", None)
        if conn is not None:
            conn.close()
            self._local.conn = None
