"""A new server: health at once, ready at once, a simulate request right after the start answered (no 503), and
``--warmup`` accepted and harmless (the 504 of a simulation past its budget: tests/test_client.py).  The service has no warm-up any more."""

from __future__ import annotations

import subprocess
import time

import httpx
import numpy as np

import dynamics
from service_fixtures import PYTHON, REPO, ROBOTS, Server

SIM = {"q0": [0.3, -0.2], "v0": [0.0, 0.5], "duration": 0.2, "sample_dt": 0.1}


def test_a_new_server_is_ready_at_once_and_simulates_right_after_its_start(tmp_path):
    server = Server(tmp_path / "store", env={"DYNAMICS_TIME_BUDGET": "30"})
    server.start(ready=False)  # returns at the first 200 of /v1/health
    try:
        with httpx.Client(base_url=server.url, timeout=60) as http:
            t0 = time.monotonic()
            ready = http.get("/v1/ready")
            assert ready.status_code == 200 and ready.json() == {"status": "ready"}
            assert http.get("/v1/health").json() == {"status": "ok"}
            assert time.monotonic() - t0 < 1.0
            # the worker may still be importing the library: the request waits for it within its budget
            r = http.post("/v1/robots/planar-2r/simulate", json=SIM)
            assert r.status_code == 200, r.text
            model = dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf"))
            expected = dynamics.simulate(model, SIM["q0"], SIM["v0"], 0.2, sample_dt=0.1, max_steps=1_000_000)
            assert np.array_equal(r.json()["q"], expected.q)
    finally:
        server.stop()


def test_warmup_flag_is_accepted_and_only_checks_the_install(tmp_path):
    env = {"PYTHONPATH": str(REPO), "DYNAMICS_ROBOTS_DIR": str(ROBOTS), "DYNAMICS_STORE": str(tmp_path / "s"),
           "PATH": "/usr/bin:/bin"}
    r = subprocess.run([PYTHON, "-m", "service", "--warmup"], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    assert "obsolete" in r.stdout and "bundled robots load" in r.stdout
