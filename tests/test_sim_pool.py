"""The simulation pool's deadline against a compilation (service.sim.pool): a job whose worker announced that it
is compiling kernels is left to finish past its request's deadline (the request is told to retry, 503), since a
killed compilation never finishes and every retry would start it again; a job that is only slow is killed at its
deadline (504), as before.  The pool here runs a stand-in worker (tests/fake_sim_worker.py) that speaks the
worker's protocol; the real worker's half, the library's announcement reaching the pool's status connection, is
checked on its own."""

from __future__ import annotations

import logging
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

from service.sim import pool as sim_pool
from service.sim.pool import PoolTimeout, SimPool

FAKE = Path(__file__).with_name("fake_sim_worker.py")


@pytest.fixture
def pool(monkeypatch):
    monkeypatch.setattr(sim_pool._Worker, "command", (sys.executable, str(FAKE)))
    p = SimPool(1)
    end = time.monotonic() + 30
    while not (p._all and all(w.warm for w in p._all)):  # its late warm-up's stages read (status thread)
        assert time.monotonic() < end, "the stand-in worker did not get ready"
        time.sleep(0.02)
    yield p
    p.close()


def _run(p, job, budget):
    return p.run(job, time.monotonic() + budget)


def test_a_compiling_job_outlives_its_deadline_and_its_worker_stays(pool):
    pid = pool.pids()[0]
    with pytest.raises(PoolTimeout) as e:
        _run(pool, (1.5, True), 0.5)
    assert e.value.args[1:] == (False, 40.0)  # not killed: retry, in about the announced seconds
    assert pool.killed == 0
    answer = _run(pool, (0.0, False), 10.0)  # waits for the worker to finish the abandoned job, then runs
    assert answer == ("done", 0.0, pid)


def test_a_slow_job_that_compiles_nothing_is_killed_at_its_deadline(pool):
    pid = pool.pids()[0]
    with pytest.raises(PoolTimeout) as e:
        _run(pool, (30.0, False), 0.5)
    assert e.value.args[1] is True and pool.killed == 1
    answer = _run(pool, (0.0, False), 30.0)  # a fresh worker took its place
    assert answer[:2] == ("done", 0.0) and answer[2] != pid


def test_the_librarys_announcement_reaches_the_pool():
    """The worker's log handler turns the library's "compiling the simulation kernels" warning into the status
    message the pool reads, with the library's own estimate."""
    from dynamics.simulation import run
    from service.sim.worker import _Announcements
    got = []
    handler = _Announcements(lambda stage, seconds: got.append((stage, seconds)))
    logger = logging.getLogger("dynamics.simulation")
    logger.addHandler(handler)
    try:
        announcing = run._announcing(SimpleNamespace(signatures=[]), ("a kind of problem", object(), True), "rk4",
                                     after=0.0)
        with announcing:  # its timer fires at once: numba gained no signature meanwhile
            announcing.timer.join(5.0)
        logger.warning("another warning")  # not an announcement: not passed on
    finally:
        logger.removeHandler(handler)
    assert got == [("compiling", float(run.COMPILE_SECONDS["rk4"]))]
