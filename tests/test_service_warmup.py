"""The warm-up at start: health at once, progress in the log, simulate waits or gets a 503 saying how long.

A real server on the (warm) numba cache of the session: its simulation worker still needs seconds to import the
library and load the integrator, a window in which a simulate request arrives. The estimate and wording of the
503 are checked on :class:`service.warmup.Warmup` directly, with stages that take as long as a test says.
"""

from __future__ import annotations

import json
import re
import threading
import time

import httpx
import numpy as np
import pytest

import dynamics
from service.warmup import FIRST_START_GUESS, Stage, Warmup
from service_fixtures import ROBOTS, Server, in_process_app

SIM = {"q0": [0.3, -0.2], "v0": [0.0, 0.5], "duration": 0.2, "sample_dt": 0.1}


def _seconds(pattern: str, text: str) -> float:
    found = re.search(pattern, text)
    assert found, (pattern, text)
    return float(found.group(1))


def test_a_new_server_answers_at_once_logs_its_stages_and_makes_simulate_wait(tmp_path):
    server = Server(tmp_path / "store", args=["--log-level", "info"])
    t0 = time.monotonic()
    server.start(ready=False)
    try:
        with httpx.Client(base_url=server.url, timeout=120) as http:
            started = time.monotonic() - t0
            # no time to warm up: 503 at once, saying for how long it has warmed up and how long it should take
            r = http.post("/v1/robots/planar-2r/simulate", json=SIM, headers={"X-Time-Budget": "0.2"})
            assert r.status_code == 503, r.text
            body = r.json()
            assert body["code"] == "starting" and body["detail"].startswith("simulate: the service has been warming up")
            assert _seconds(r"warming up for ([\d.]+) s", body["detail"]) <= started + 30
            assert _seconds(r"ready in about ([\d.]+) s", body["detail"]) > 0 and "no earlier start" in body["detail"]
            assert 1 <= int(r.headers["retry-after"]) <= 60
            t1 = time.monotonic()
            assert http.get("/v1/health").json() == {"status": "ok"}  # during the warm-up, at once
            assert time.monotonic() - t1 < 1.0
            # a budget long enough: the request waits for the worker, then gets the library's numbers
            r = http.post("/v1/robots/planar-2r/simulate", json=SIM, headers={"X-Time-Budget": "120"})
            assert r.status_code == 200, r.text
            model = dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf"))
            expected = dynamics.simulate(model, SIM["q0"], SIM["v0"], 0.2, sample_dt=0.1, max_steps=1_000_000)
            assert np.array_equal(r.json()["q"], expected.q)
            deadline = time.monotonic() + 60
            while (ready := http.get("/v1/ready")).status_code == 503 and time.monotonic() < deadline:
                time.sleep(0.1)
            assert ready.status_code == 200 and ready.json()["warmup_seconds"] > 0
            assert ready.json()["status"] == "ready" and ready.json()["failures"] == []
    finally:
        server.stop()
    log = server.log.read_text()
    for stage, name in enumerate(["importing the library", "compiling dynamics kernels",
                                  "compiling simulation kernels in 1 worker process",
                                  "compiling the operational-space and computed-torque simulation kernels"], start=1):
        assert f"warm-up: {name} (stage {stage}/4) ..." in log, log
        _seconds(rf"warm-up: {re.escape(name)} \(stage {stage}/4\) done in ([\d.]+) s", log)
    took = _seconds(r"warm-up: ready after ([\d.]+) s", log)
    assert json.loads((server.store / ".warmup.json").read_text())["seconds"] == pytest.approx(took, abs=0.05)

    # the next start on the same store estimates from this one
    server.start(ready=False)
    try:
        r = httpx.get(server.url + "/v1/ready", timeout=10)
        if r.status_code == 503:  # (unless it was already warm: nothing left to say)
            assert "the last start took" in r.json()["detail"]
            assert _seconds(r"the last start took ([\d.]+) s", r.json()["detail"]) == pytest.approx(took, abs=0.5)
    finally:
        server.stop()


# -- the estimate, on a Warmup with stages of known length -------------------------------------------------------
def _blocked_warmup(tmp_path, history: float | None):
    """A warm-up whose second stage lasts until the returned event is set; ``history``: the last start's seconds."""
    path = tmp_path / f"warmup-{history}.json"
    if history is not None:
        path.write_text(json.dumps({"seconds": history}))
    release = threading.Event()
    warmup = Warmup(path)
    warmup.start([Stage("importing the library", lambda: None), Stage("compiling simulation kernels", release.wait)])
    time.sleep(0.1)
    return warmup, release, path


def test_status_estimates_from_the_last_start(tmp_path):
    warmup, release, path = _blocked_warmup(tmp_path, history=40.0)
    assert not warmup.done and 39 <= warmup.remaining() <= 40
    status = warmup.status()
    assert "compiling simulation kernels (stage 2/2)" in status and "ready in about 40 s" in status
    assert "the last start took 40 s" in status and warmup.retry_after() == 40
    release.set()
    time.sleep(0.1)
    assert warmup.done and warmup.remaining() == 0
    assert json.loads(path.read_text())["seconds"] == pytest.approx(warmup.seconds)  # the next start's estimate


def test_status_without_history_guesses_and_past_the_estimate_says_shortly(tmp_path):
    warmup, release, _ = _blocked_warmup(tmp_path, history=None)
    assert "no earlier start is recorded" in warmup.status()
    assert warmup.remaining() == pytest.approx(FIRST_START_GUESS, abs=1) and warmup.retry_after() == 60
    release.set()
    warmup, release, _ = _blocked_warmup(tmp_path, history=0.05)
    time.sleep(0.1)
    assert "longer than expected" in warmup.status() and "shortly" in warmup.status()
    assert warmup.retry_after() == 5
    release.set()


def test_a_failed_stage_is_logged_and_the_next_one_runs(caplog):
    ran = []

    def broken():
        raise RuntimeError("no compiler")

    with caplog.at_level("INFO", logger="service"):
        Warmup().run([Stage("one", broken), Stage("two", lambda: ran.append(2))])
    assert ran == [2]
    text = caplog.text
    assert "warm-up: one (stage 1/2) failed" in text and "no compiler" in text
    assert "warm-up: two (stage 2/2) done in" in text and "warm-up: ready after" in text


def test_the_rest_of_the_warm_up_reaches_radau_and_the_free_joint(monkeypatch):
    """warm_up_rest compiles what it says: its stiff PD makes auto switch to radau, its floating model has a free
    joint, and it runs contact under a PD controller that touches the ground (seen through the simulations it
    runs)."""
    from service.sim import warm
    runs = []
    simulate = dynamics.simulate
    monkeypatch.setattr(dynamics, "simulate",
                        lambda model, *a, **k: runs.append((model, k, simulate(model, *a, **k))))
    warm.warm_up_rest()
    assert any(tr.report["switches"] and tr.report["switches"][0]["to"] == "radau" for _, _, tr in runs)
    assert any(model.nq == model.nv + 1 for model, _, _ in runs)  # a quaternion: the free joint
    assert any(isinstance(k.get("torque"), dynamics.torques.PD) and k.get("contact") is not None
               and tr.report["contact"]["max_penetration"] > 0 for _, k, tr in runs)
    assert all(tr.report["status"] == "ok" for _, _, tr in runs)


def test_the_late_warm_up_compiles_and_warmup_failures_fail_the_build(monkeypatch, capsys):
    """Issue 25 A3: warm_up_later ran a Target without posture_kp (None, read as NaN) and crashed in every
    worker; ``python -m service --warmup`` printed the traceback and exited 0."""
    from service import __main__ as main
    from service.sim import warm
    runs = []
    simulate = dynamics.simulate
    monkeypatch.setattr(dynamics, "simulate", lambda model, *a, **k: runs.append(simulate(model, *a, **k)))
    warm.warm_up_later()  # compiles, no exception
    # and each of its simulations runs to its end (an operational-space task singular at t = 0 stopped there
    # with a SimulationWarning in every worker's log)
    assert len(runs) == 2 and all(tr.report["status"] == "ok" and tr.t[-1] == 0.01 for tr in runs), \
        [(tr.report["status"], tr.t[-1]) for tr in runs]
    monkeypatch.undo()
    monkeypatch.setattr(main, "compile_operations", lambda *a, **k: None)  # (the dynamics stage is not the point)
    monkeypatch.setattr(warm, "warm_up", lambda: None)
    monkeypatch.setattr(warm, "warm_up_rest", lambda: None)

    def broken():
        raise RuntimeError("no compiler here")

    monkeypatch.setattr(warm, "warm_up_later", broken)
    assert main.warmup() == 1
    assert "FAILED compiling the operational-space simulation kernels: RuntimeError: no compiler here" in \
        capsys.readouterr().err
    monkeypatch.setattr(warm, "warm_up_later", lambda: None)
    assert main.warmup() == 0


def test_a_failed_late_warm_up_shows_in_ready(monkeypatch, tmp_path):
    """A worker whose late warm-up failed: /v1/ready says "degraded" and names the stage and the error."""
    from service.sim.pool import SimPool
    monkeypatch.setattr(SimPool, "wait_late", lambda self: (_ for _ in ()).throw(
        RuntimeError("the operational-space and computed-torque kernels did not compile: boom")))
    with in_process_app(tmp_path, sim_workers=1) as client:
        deadline = time.monotonic() + 600
        while (r := client.get("/v1/ready")).status_code == 503 and time.monotonic() < deadline:
            time.sleep(0.2)
        body = r.json()
        assert r.status_code == 200 and body["status"] == "degraded", body
        assert body["failures"] == [{"stage": "compiling the operational-space and computed-torque simulation "
                                              "kernels", "error": "RuntimeError: the operational-space and "
                                                                  "computed-torque kernels did not compile: boom"}]


def test_a_workers_compiling_line_is_printed_once_with_a_time():
    """Issue 25 D16: each worker printed the library's "compiling ..." line twice, bare (Python's last-resort
    handler). The worker's logging prints it once, with a time and its pid."""
    import subprocess
    import sys
    code = ("import logging; from service.settings import configure_worker_logging; configure_worker_logging(); "
            "log = logging.getLogger('dynamics.simulation.run'); "
            "[log.warning('compiling the simulation kernels for %r (first run)', 'rk4') for _ in range(2)]")
    err = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                         cwd=ROBOTS.parent).stderr
    lines = [line for line in err.splitlines() if "compiling" in line]
    assert len(lines) == 1 and re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d+ WARNING worker \d+ ", lines[0]), err


def test_a_request_that_ran_into_a_compilation_gets_503_not_504():
    """Issue 25 A3: a first operational-space simulate on a cold start answered 504 after 10 s ("shorten the
    duration"): its worker was compiling. A request whose worker had not finished its warm-up gets the 503 with
    Retry-After; one whose worker was warm keeps the 504 and its advice."""
    from types import SimpleNamespace

    from service.compute import Budget, Compute
    from service.errors import BudgetExceeded, Unavailable
    from service.sim.pool import PoolTimeout

    def pool(warm):
        def run(job, deadline):
            raise PoolTimeout("the simulation ran past the deadline; its worker was stopped", warm)
        return SimpleNamespace(run=run)

    from service.sim.job import Job
    job = Job("r", "<robot/>", False, (), np.zeros(1), np.zeros(1), 1.0, {}, None, 1000)
    with pytest.raises(Unavailable) as e:
        Compute._simulate(SimpleNamespace(pool=pool(False)), job, Budget.starting_now(10.0))
    assert e.value.code == "starting" and e.value.headers["Retry-After"].isdigit() and "compiling" in e.value.detail
    with pytest.raises(BudgetExceeded) as e:
        Compute._simulate(SimpleNamespace(pool=pool(True)), job, Budget.starting_now(10.0))
    assert "shorten the duration" in e.value.detail
