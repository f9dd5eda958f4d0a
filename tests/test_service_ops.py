"""Operating the service: API keys and ownership, SIGKILL and restart on the same store, the time budget.

One server with keys, a small time budget and a large body limit; it is killed with SIGKILL half-way and
restarted on the same store.
"""

from __future__ import annotations

import io
import os
import time

import httpx
import numpy as np
import pytest

import dynamics
from service_fixtures import ROBOTS, Server

KEY_A, KEY_B = "key-a-0123456789", "key-b-9876543210"
BUDGET = 0.25


def cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    root = tmp_path_factory.mktemp("ops")
    s = Server(root / "store", env={"DYNAMICS_API_KEYS": f"{KEY_A}, {KEY_B}",
                                    "DYNAMICS_TIME_BUDGET": str(BUDGET),
                                    "DYNAMICS_MAX_BODY_BYTES": str(48 << 20),
                                    "DYNAMICS_MAX_BATCH": "2000000", "DYNAMICS_MAX_ANSWER_BYTES": str(512 << 20)})
    s.start()
    yield s
    s.stop()


def client(server, key):
    return httpx.Client(base_url=server.url, timeout=60,
                        headers={"Authorization": f"Bearer {key}"} if key else {})


def test_api_keys_and_owner_only_delete(server):
    text = (ROBOTS / "planar_3r.urdf").read_bytes()
    with client(server, None) as anon, client(server, KEY_A) as a, client(server, KEY_B) as b, \
            client(server, "wrong") as wrong:
        assert anon.get("/v1/health").status_code == 200
        for c in (anon, wrong):
            r = c.get("/v1/robots")
            assert r.status_code == 401 and r.json()["field"] == "Authorization"
            assert r.headers["www-authenticate"] == "Bearer"
            assert c.get("/openapi.json").status_code == 401
        ra = a.post("/v1/robots", content=text, headers={"Content-Type": "application/xml"})
        rb = b.post("/v1/robots", content=text, headers={"Content-Type": "application/xml"})
        assert ra.status_code == rb.status_code == 201
        assert ra.json()["id"] != rb.json()["id"]  # one robot per owner: neither sees the other's (issue 11)
        assert b.delete(f"/v1/robots/{ra.json()['id']}").status_code == 404
        assert wrong.delete(f"/v1/robots/{ra.json()['id']}").status_code == 401
        assert a.delete(f"/v1/robots/{rb.json()['id']}").status_code == 404
        assert b.delete(f"/v1/robots/{rb.json()['id']}").status_code == 204
        assert b.get(f"/v1/robots/{ra.json()['id']}").status_code == 404
        assert a.get(f"/v1/robots/{ra.json()['id']}").status_code == 200


def test_sigkill_and_restart_keeps_robots_and_numbers(server):
    text = (ROBOTS / "puma560.urdf").read_text().replace('name="puma560"', 'name="puma-copy"', 1)
    model = dynamics.load_urdf(text.encode())
    rng = np.random.default_rng(5)
    q, v, a = rng.normal(size=(3, 4, model.nq))
    payload = {"q": q.tolist(), "v": v.tolist(), "a": a.tolist()}
    with client(server, KEY_A) as c:
        rid = c.post("/v1/robots", json={"urdf": text, "floating_base": True}).json()["id"]
        qf = np.concatenate([np.tile([0.1, 0.2, 0.3, 0, 0, 0, 1.0], (4, 1)), q], axis=1)
        vf = np.concatenate([np.zeros((4, 6)), v], axis=1)
        fpayload = {"q": qf.tolist(), "v": vf.tolist(), "a": vf.tolist()}
        before = c.post(f"/v1/robots/{rid}/inverse-dynamics", json=fpayload).json()["tau"]
        rid2 = c.post("/v1/robots", json={"urdf": text}).json()["id"]
        before2 = c.post(f"/v1/robots/{rid2}/inverse-dynamics", json=payload).json()["tau"]
    server.kill()  # SIGKILL: no shutdown handler runs
    server.start()
    with client(server, KEY_A) as c, client(server, KEY_B) as b:
        ids = {r["id"] for r in c.get("/v1/robots").json()["robots"]}
        assert {rid, rid2} <= ids
        assert c.post(f"/v1/robots/{rid}/inverse-dynamics", json=fpayload).json()["tau"] == before
        assert c.post(f"/v1/robots/{rid2}/inverse-dynamics", json=payload).json()["tau"] == before2
        assert b.delete(f"/v1/robots/{rid}").status_code == 404  # ownership survived the restart
    assert np.array_equal(before2, dynamics.inverse_dynamics(model, q, v, a))
    assert not list(server.store.glob(".*.tmp"))


def test_time_budget_stops_the_work(server):
    """An 800k-state mass-matrix batch cannot finish in 0.25 s: 504, and the server's CPU goes idle at once."""
    q = np.random.default_rng(0).normal(size=(800_000, 6))
    buf = io.BytesIO()
    np.savez(buf, q=q)
    with client(server, KEY_A) as c:
        # the model into the server's cache first, so that the budget below is the batch's alone
        warm = c.post("/v1/robots/puma560/mass-matrix", json={"q": q[:3].tolist()})
        assert warm.status_code == 200, warm.text
        t0 = time.monotonic()
        r = c.post("/v1/robots/puma560/mass-matrix", content=buf.getvalue(),
                   headers={"Content-Type": "application/x-npz", "Accept": "application/x-npz"})
        elapsed = time.monotonic() - t0
        assert r.status_code == 504, r.text[:300]
        body = r.json()
        assert body["code"] == "time_budget_exceeded" and "DYNAMICS_TIME_BUDGET" in body["detail"]
        assert elapsed < BUDGET + 2.0
        cpu0 = cpu_seconds(server.proc.pid)
        time.sleep(0.5)
        assert cpu_seconds(server.proc.pid) - cpu0 < 0.15  # nothing keeps computing behind the 504
        assert c.post("/v1/robots/puma560/mass-matrix", json={"q": [0.0] * 6}).status_code == 200
