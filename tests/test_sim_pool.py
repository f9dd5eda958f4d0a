"""The simulation pool (service.sim.pool) with a stand-in worker (tests/fake_sim_worker.py) that speaks the
worker's protocol: a job that is only slow (its worker never answers) is killed shortly past its deadline and
replaced; a crashed worker is replaced and named in the error; a job answered in time keeps its worker.  (The
real worker stops at the deadline by itself, the C++ core checking it: tests/test_service_start.py.)"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest

from service.sim import pool as sim_pool
from service.sim.pool import KILL_GRACE, PoolTimeout, SimPool, WorkerCrashed

FAKE = Path(__file__).with_name("fake_sim_worker.py")


@pytest.fixture
def pool(monkeypatch):
    monkeypatch.setattr(sim_pool._Worker, "command", (sys.executable, str(FAKE)))
    p = SimPool(1)
    assert p.wait_ready(30), "the stand-in worker did not get ready"
    yield p
    p.close()


def _run(p, job, budget):
    return p.run(job, time.monotonic() + budget)


def test_a_job_answered_in_time_keeps_its_worker(pool):
    pid = pool.pids()[0]
    assert _run(pool, 0.0, 10.0) == ("done", 0.0, pid)
    assert _run(pool, 0.1, 10.0) == ("done", 0.1, pid) and pool.killed == 0


def test_a_job_that_never_answers_is_killed_shortly_past_its_deadline(pool):
    pid = pool.pids()[0]
    t0 = time.monotonic()
    with pytest.raises(PoolTimeout):
        _run(pool, 30.0, 0.5)
    assert 0.5 <= time.monotonic() - t0 < 0.5 + KILL_GRACE + 1.0
    assert pool.killed == 1
    answer = _run(pool, 0.0, 30.0)  # a fresh worker took its place
    assert answer[:2] == ("done", 0.0) and answer[2] != pid


def test_a_crashed_worker_is_replaced(pool):
    pid = pool.pids()[0]
    with pytest.raises(WorkerCrashed, match="code 3"):
        _run(pool, "crash", 10.0)
    answer = _run(pool, 0.0, 30.0)
    assert answer[:2] == ("done", 0.0) and answer[2] != pid
