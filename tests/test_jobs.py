"""Jobs against real server processes: submit, poll, fetch, cancel; ownership; limits; a SIGKILLed server
restarted on the same store loses no job; results equal the library's, bit for bit."""

from __future__ import annotations

import json
import os
import signal
import socket
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

import dynamics
from dynamics import engines
from dynamics.torques import PD, ComputedTorque, OperationalSpace, Table, Target, TaskReference
from service.client import Client, ServiceError
from service.jobs.db import JobDB
from service.jobs.executor import Executor
from service.jobs.files import JobFiles, write_npz
from service.settings import Settings
from service_fixtures import ROBOTS, Server

KEYS = {"DYNAMICS_API_KEYS": "alice-key,bob-key", "DYNAMICS_JOB_PART_SECONDS": "0.2",
        "DYNAMICS_MAX_JOBS_PER_KEY": "3"}
#: a simulation job long enough to be caught running (seconds on a loaded machine), with many parts
LONG = {"duration": 1.0, "integrator": "rk4", "dt": 1e-3, "sample_dt": 0.1, "error_estimate": "none"}


def planar3():
    return dynamics.load_urdf((ROBOTS / "planar_3r.urdf").read_bytes())


def long_inputs(n, seed=0):
    model = planar3()
    rng = np.random.default_rng(seed)
    q0 = rng.uniform(-1, 1, (n, model.nq))
    return {"q0": q0, "v0": np.zeros(model.nv),
            "torque": {"type": "pd", "q_target": rng.uniform(-1, 1, (n, model.nq)), "kp": 50.0, "kd": 5.0}}


def descendants(pid):
    """[(pid, command line)] of every process below ``pid`` (from /proc)."""
    parents = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            parents[int(stat.parent.name)] = int(fields[1])
        except (OSError, IndexError, ValueError):
            continue
    found, frontier = [], [pid]
    while frontier:
        kids = [p for p, parent in parents.items() if parent in frontier]
        found += kids
        frontier = kids
    out = []
    for p in found:
        try:
            out.append((p, (Path("/proc") / str(p) / "cmdline").read_bytes().replace(b"\0", b" ").decode()))
        except OSError:
            pass
    return out


def wait_for(job, predicate, timeout=300.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        info = job.status()
        if predicate(info):
            return info
        time.sleep(0.1)
    raise AssertionError(f"job {job.id} never reached the state wanted: {job.status()}")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    s = Server(tmp_path_factory.mktemp("jobs") / "store", env=KEYS).start()
    yield s
    s.stop()


@pytest.fixture(scope="module")
def alice(server):
    with Client(server.url, api_key="alice-key") as c:
        yield c


@pytest.fixture(scope="module")
def bob(server):
    with Client(server.url, api_key="bob-key") as c:
        yield c


def test_inverse_dynamics_job_equals_one_library_call(alice):
    model = dynamics.load_urdf((ROBOTS / "puma560.urdf").read_bytes())
    q, v, a = np.random.default_rng(1).normal(size=(3, 30_000, model.nq))
    t0 = time.monotonic()
    job = alice.submit("puma560", "inverse_dynamics", {"q": q, "v": v, "a": a})
    assert time.monotonic() - t0 < 30 and job.info["status"] in ("queued", "running")  # never run in the request
    final = job.wait(timeout=300)
    assert final["status"] == "done", final
    assert final["progress"] == {"done": 30_000, "total": 30_000, "fraction": 1.0}
    assert final["timing"]["compute_seconds"] > 0 and final["result_bytes"] > 0
    assert np.array_equal(job.result()["tau"], dynamics.inverse_dynamics(model, q, v, a))


def test_json_job_and_small_json_result(server):
    model = dynamics.load_urdf((ROBOTS / "planar_2r.urdf").read_bytes())
    q = np.random.default_rng(2).normal(size=(50, 2))
    headers = {"Authorization": "Bearer alice-key"}
    r = httpx.post(server.url + "/v1/jobs", headers=headers, json={
        "robot": "planar-2r", "kind": "mass_matrix", "inputs": {"q": q.tolist()}})
    assert r.status_code == 202, r.text
    assert r.headers["location"] == r.json()["status_url"]
    job = Client(server.url, api_key="alice-key").job(r.json()["id"])
    assert job.wait(timeout=300)["status"] == "done"
    answer = httpx.get(server.url + r.json()["status_url"] + "/result", headers=headers)
    assert answer.headers["content-type"] == "application/json"
    assert np.array_equal(np.array(answer.json()["mass_matrix"]), dynamics.mass_matrix(model, q))


def test_simulate_many_job_equals_simulate_run_by_run(alice):
    model = planar3()
    inputs = long_inputs(12, seed=3)
    options = dict(LONG, duration=0.3)
    job = alice.submit("planar-3r", "simulate_many", inputs, options)
    assert job.wait(timeout=300)["status"] == "done"
    out = job.result()
    assert out["q"].shape == (12, 4, model.nq) and list(out["counts"]) == [4] * 12
    assert [r["run"] for r in out["reports"]] == list(range(12))
    for k in (0, 7, 11):
        one = dynamics.simulate(model, inputs["q0"][k], inputs["v0"], 0.3,
                                torque=PD(inputs["torque"]["q_target"][k], 50.0, 5.0),
                                **{k2: v for k2, v in LONG.items() if k2 != "duration"})
        assert np.array_equal(out["t"], one.t)
        assert np.array_equal(out["q"][k], one.q) and np.array_equal(out["tau"][k], one.tau)


def every_torque_kind(model):
    """(name, the library's torque, its HTTP spec) of every torque kind /simulate takes, on a planar 3R arm."""
    t = np.linspace(0.0, 0.3, 4)
    q = np.outer(np.sin(t), np.ones(model.nq))
    p0 = np.array([1.0, 0.0, 0.5])
    path = p0 + np.outer(t, [0.0, 0.0, -0.2])
    return [("zero", None, {"type": "zero"}),
            ("constant", np.array([0.1, 0.0, -0.1]), {"type": "constant", "tau": [0.1, 0.0, -0.1]}),
            ("table", Table(t, np.outer(t, [1.0, 0.5, 0.2]), hold="zoh"),
             {"type": "table", "t": t, "tau": np.outer(t, [1.0, 0.5, 0.2]), "hold": "zoh"}),
            ("pd", PD(np.ones(3), 50.0, 5.0), {"type": "pd", "q_target": np.ones(3), "kp": 50.0, "kd": 5.0}),
            ("computed_torque", ComputedTorque(t, q, np.gradient(q, t, axis=0), np.zeros_like(q), 40.0, 10.0),
             {"type": "computed_torque", "t": t, "q": q, "v": np.gradient(q, t, axis=0), "a": np.zeros_like(q),
              "kp": 40.0, "kd": 10.0}),
            ("operational_space reference", OperationalSpace("link3", TaskReference(t, path), 20.0, 8.0, rows=[0, 2]),
             {"type": "operational_space", "frame": "link3", "reference": {"t": t, "position": path},
              "kp": 20.0, "kd": 8.0, "rows": [0, 2]}),
            ("operational_space position", Target("link3", p0, kp=20.0, kd=8.0, rows=[0, 2]),
             {"type": "operational_space", "frame": "link3", "position": p0, "kp": 20.0, "kd": 8.0,
              "rows": [0, 2]})]


def test_every_torque_kind_runs_as_a_job_as_in_simulate(alice, server):
    """Issue 25 A1: an operational-space torque with a reference answered 500 (an array in the database's JSON)
    and left its inputs file behind; with a position the job failed. Every kind now gives, run by run, what
    dynamics.simulate gives, sent as a spec (JSON and .npz) and as the library's own object."""
    model = planar3()
    q0 = np.array([[0.3, 0.6, -0.4], [0.1, 0.2, 0.3]])
    options = {"duration": 0.3, "integrator": "rk4", "dt": 1e-3, "sample_dt": 0.1, "error_estimate": "none"}
    for name, torque, spec in every_torque_kind(model):
        expected = [dynamics.simulate(model, q, np.zeros(3), 0.3, torque=torque,
                                      **{k: v for k, v in options.items() if k != "duration"}) for q in q0]
        sent = [spec] + ([torque] if torque is not None and not isinstance(torque, np.ndarray) else [])
        for how in sent:
            job = alice.submit("planar_3r", "simulate_many", {"q0": q0, "v0": np.zeros(3), "torque": how}, options)
            info = job.wait(timeout=300)
            assert info["status"] == "done", (name, info)
            out = job.result()
            for k in range(2):
                assert np.array_equal(out["q"][k], expected[k].q), name
                assert np.array_equal(out["tau"][k], expected[k].tau), name
    body = {"robot": "planar_3r", "kind": "simulate_many", "options": options,  # plain JSON, nested reference
            "inputs": {"q0": q0.tolist(), "v0": [0, 0, 0], "torque": {**every_torque_kind(model)[5][2],
                                                                      "reference": {"t": [0.0, 0.3],
                                                                                    "position": [[1, 0, 0.5]] * 2}}}}
    r = httpx.post(server.url + "/v1/jobs", json=body, headers={"Authorization": "Bearer alice-key"})
    assert r.status_code == 202, r.text


def test_a_torque_the_library_refuses_is_a_422_at_submission_and_leaves_no_file(alice, server):
    """A bad spec is refused when submitted (naming the field), and a refused submit leaves nothing on disk."""
    before = sorted((server.store / "jobs" / "inputs").iterdir())
    cases = [({"type": "operational_space", "frame": "link3", "kp": 1.0, "kd": 1.0}, "inputs.torque.reference"),
             ({"type": "operational_space", "frame": "nope", "position": [1, 0, 0], "kp": 1.0, "kd": 1.0},
              "inputs.torque.frame"),
             ({"type": "operational_space", "frame": "link3", "reference": {"t": [0.0, 1.0], "position": [[1, 0]]},
               "kp": 1.0, "kd": 1.0}, "inputs.torque.reference.position"),
             ({"type": "pd", "q_target": np.ones((5, 3)), "kp": 1.0, "kd": 1.0}, "inputs.q0"),  # 5 runs or 2?
             ({"type": "pd", "q_target": [1.0, 2.0], "kp": 1.0, "kd": 1.0}, "inputs.torque.q_target")]
    for spec, field in cases:
        with pytest.raises(ServiceError) as e:
            alice.submit("planar_3r", "simulate_many", {"q0": np.zeros((2, 3)), "v0": np.zeros(3), "torque": spec},
                         {"duration": 0.1})
        assert (e.value.status, e.value.field) == (422, field), e.value.message
    # nothing new (an earlier test's job may finish meanwhile and take its own inputs file with it)
    assert set((server.store / "jobs" / "inputs").iterdir()) <= set(before)


def test_a_job_belongs_to_its_key(alice, bob, server):
    job = alice.submit("planar-2r", "mass_matrix", {"q": np.zeros((3, 2))})
    job.wait(timeout=300)
    for call in (lambda: bob.job(job.id), lambda: Client(server.url, api_key="bob-key").request(
            "GET", f"/v1/jobs/{job.id}/result"), lambda: bob.request("DELETE", f"/v1/jobs/{job.id}")):
        with pytest.raises(ServiceError) as e:
            call()
        assert e.value.status == 404 and e.value.code == "not_found"
    assert job.id not in [j["id"] for j in bob.jobs()]
    assert job.id in [j["id"] for j in alice.jobs()]
    assert httpx.get(server.url + f"/v1/jobs/{job.id}").status_code == 401  # no key at all
    assert alice.job(job.id).result()["mass_matrix"].shape == (3, 2, 2)  # still there for its owner


def test_cancel_a_running_job_and_remove_a_finished_one(alice, server):
    job = alice.submit("planar-3r", "simulate_many", long_inputs(3000), LONG)
    wait_for(job, lambda i: i["status"] == "running" and i["progress"]["done"] > 0)
    with pytest.raises(ServiceError) as e:
        job.result()
    assert e.value.status == 409 and e.value.code == "not_ready"
    assert job.cancel()["status"] == "cancelled"
    info = job.status()
    assert info["status"] == "cancelled" and info["progress"]["done"] < 3000
    # the runner notices at its next part and stops (a part takes longer on a loaded machine): still cancelled,
    # its parts removed, no result
    parts = server.store / "jobs" / "parts" / job.id
    end = time.monotonic() + 60.0
    while parts.exists() and time.monotonic() < end:
        time.sleep(0.1)
    assert job.status()["status"] == "cancelled"
    assert not parts.exists()
    assert job.cancel()["status"] == "removed"  # a finished (cancelled) job is removed
    with pytest.raises(ServiceError) as e:
        job.status()
    assert e.value.status == 404


def test_refusals_name_the_field(alice, server):
    cases = [({"robot": "planar-2r", "kind": "jacobian", "inputs": {}}, 422, "kind"),
             ({"robot": "nope", "kind": "mass_matrix", "inputs": {"q": [[0, 0]]}}, 404, "robot"),
             ({"robot": "planar-2r", "kind": "inverse_dynamics", "inputs": {"q": [[0, 0]], "v": [[0, 0]],
                                                                            "a": [[0, 0, 0]]}}, 422, "inputs.a"),
             ({"robot": "planar-2r", "kind": "simulate_many", "inputs": {"q0": [0, 0], "v0": [0, 0]}}, 422,
              "options.duration"),
             ({"robot": "planar-2r", "kind": "mass_matrix", "inputs": {"q": [[0, 0]], "x": [1]}}, 422, "inputs.x"),
             ({"robot": "planar-2r", "kind": "simulate_many", "options": {"duration": 1},
               "inputs": {"q0": [0, 0], "v0": [0, 0], "torque": {"type": "pd", "q_target": [0, 0]}}}, 422,
              "inputs.torque.kp")]
    for body, status, field in cases:
        r = httpx.post(server.url + "/v1/jobs", json=body, headers={"Authorization": "Bearer alice-key"})
        assert (r.status_code, r.json()["field"]) == (status, field), r.text
    with socket.create_connection(("127.0.0.1", server.port), timeout=60) as sock:  # a body declared too large
        sock.sendall(b"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer alice-key\r\n"
                     b"Content-Type: application/json\r\nContent-Length: 1099511627776\r\n\r\n{")
        answer = b""
        while b"DYNAMICS_MAX_JOB_INPUT_BYTES" not in answer:  # the head and the body may come apart
            chunk = sock.recv(4096)
            if not chunk:
                break
            answer += chunk
    assert answer.startswith(b"HTTP/1.1 413") and b"DYNAMICS_MAX_JOB_INPUT_BYTES" in answer, answer


def test_too_many_jobs_per_key(bob):
    jobs = [bob.submit("planar-3r", "simulate_many", long_inputs(2000), LONG) for _ in range(3)]
    with pytest.raises(ServiceError) as e:
        bob.submit("planar-2r", "mass_matrix", {"q": np.zeros((1, 2))})
    assert e.value.status == 429 and "DYNAMICS_MAX_JOBS_PER_KEY" in e.value.message
    for job in jobs:
        job.cancel()
    assert bob.submit("planar-2r", "mass_matrix", {"q": np.zeros((1, 2))}).wait(timeout=300)["status"] == "done"


def test_sigkill_mid_job_loses_nothing(tmp_path):
    env = dict(KEYS, DYNAMICS_JOB_ATTEMPTS="2")
    server = Server(tmp_path / "store", env=env).start()
    client = Client(server.url, api_key="alice-key")
    model = planar3()
    try:
        q = np.random.default_rng(4).normal(size=(1000, model.nq))
        finished = client.submit("planar-3r", "mass_matrix", {"q": q})
        assert finished.wait(timeout=300)["status"] == "done"
        inputs = long_inputs(600, seed=5)
        running = client.submit("planar-3r", "simulate_many", inputs, LONG)
        queued = client.submit("planar-3r", "inverse_dynamics", {"q": q, "v": q, "a": q})
        before = wait_for(running, lambda i: i["status"] == "running" and i["progress"]["done"] > 0)
        children = descendants(server.proc.pid)  # simulation workers, job workers (one mid-part now)
        assert any("spawn_main" in cmd for _, cmd in children) and any("service.sim.worker" in cmd
                                                                        for _, cmd in children)
        server.kill_alone()  # issue 25 A2: its workers lived on for 30 minutes, re-parented to PID 1
        end = time.monotonic() + 5.0
        while (alive := [c for c in children if Path(f"/proc/{c[0]}").exists()
                         and "zombie" not in Path(f"/proc/{c[0]}/status").read_text()]) and time.monotonic() < end:
            time.sleep(0.1)
        assert not alive, f"workers outlived their server by 5 s: {alive}"
        server = Server(tmp_path / "store", env=env).start()
        client = Client(server.url, api_key="alice-key")
        assert np.array_equal(client.job(finished.id).result()["mass_matrix"], dynamics.mass_matrix(model, q))
        after = client.job(running.id).wait(timeout=600)
        assert after["status"] == "done", after
        assert after["attempts"] == 2 and "restarted" in after["error"]  # resumed, and it says why
        assert before["progress"]["done"] < 600
        out = client.job(running.id).result()
        assert out["q"].shape[0] == 600 and np.isfinite(out["q"]).all()
        assert [r["run"] for r in out["reports"]] == list(range(600))
        for k in (0, before["progress"]["done"], 599):  # before, across and after the restart
            one = dynamics.simulate(model, inputs["q0"][k], inputs["v0"], 1.0,
                                    torque=PD(inputs["torque"]["q_target"][k], 50.0, 5.0),
                                    **{k2: v for k2, v in LONG.items() if k2 != "duration"})
            assert np.array_equal(out["q"][k], one.q)
        assert client.job(queued.id).wait(timeout=300)["status"] == "done"
        assert np.array_equal(client.job(queued.id).result()["tau"], dynamics.inverse_dynamics(model, q, q, q))
    finally:
        server.stop()


def test_a_job_out_of_attempts_fails_with_the_reason(tmp_path):
    env = dict(KEYS, DYNAMICS_JOB_ATTEMPTS="1")
    server = Server(tmp_path / "store", env=env).start()
    try:
        job = Client(server.url, api_key="alice-key").submit("planar-3r", "simulate_many", long_inputs(3000), LONG)
        wait_for(job, lambda i: i["status"] == "running")
        server.kill()
        server = Server(tmp_path / "store", env=env).start()
        info = Client(server.url, api_key="alice-key").job(job.id).wait(timeout=120)
        assert info["status"] == "failed" and "server running it stopped" in info["error"], info
        assert json.dumps(info)  # plain JSON all the way
    finally:
        server.stop()


def test_with_a_ray_address_the_parts_run_on_ray(tmp_path):
    ray = pytest.importorskip("ray")
    engines.ray_init(num_cpus=2)  # a local Ray owned by this test process; the server's job worker joins it
    try:
        address = ray.get_runtime_context().gcs_address
        server = Server(tmp_path / "store", env=dict(KEYS, DYNAMICS_RAY_ADDRESS=address)).start()
        try:
            client = Client(server.url, api_key="alice-key")
            model = planar3()
            q = np.random.default_rng(6).normal(size=(20_000, model.nq))
            job = client.submit("planar-3r", "inverse_dynamics", {"q": q, "v": q, "a": q})
            assert job.wait(timeout=300)["status"] == "done", job.status()
            assert np.array_equal(job.result()["tau"], dynamics.inverse_dynamics(model, q, q, q))
            assert "Ray cluster" in server.log.read_text()  # the job worker joined it as a driver
        finally:
            server.stop()
    finally:
        ray.shutdown()


def test_a_run_that_blows_up_does_not_sink_the_job(alice, server):
    q0 = np.zeros((2, 3))
    kp = np.array([[50.0] * 3, [1e9] * 3])  # one row per run: the second is far past rk4's stability limit
    job = alice.submit("planar-3r", "simulate_many", {"q0": q0, "v0": np.zeros(3), "torque": {
        "type": "pd", "q_target": np.ones(3), "kp": kp, "kd": 5.0}}, dict(LONG, duration=0.3))
    assert job.wait(timeout=300)["status"] == "done"
    out = job.result()
    assert out["reports"][0]["status"] == "ok" and out["reports"][1]["status"].startswith("unstable")
    assert out["counts"][0] == 4 and out["counts"][1] < 4 and np.isnan(out["q"][1, -1]).all()
    one = dynamics.simulate(planar3(), q0[0], np.zeros(3), 0.3, torque=PD(np.ones(3), kp[0], 5.0),
                            **{k: v for k, v in LONG.items() if k != "duration"})
    assert np.array_equal(out["q"][0], one.q)
    r = httpx.get(server.url + f"/v1/jobs/{job.id}/result", headers={"Authorization": "Bearer alice-key"})
    assert r.headers["content-type"] == "application/x-npz"  # JSON has no NaN


def test_a_dead_job_worker_process_is_replaced_and_the_job_resumes(alice, server):
    inputs = long_inputs(400, seed=7)
    job = alice.submit("planar-3r", "simulate_many", inputs, LONG)
    wait_for(job, lambda i: i["status"] == "running" and i["progress"]["done"] > 0)
    workers = [pid for pid, cmd in descendants(server.proc.pid) if "spawn_main" in cmd]
    assert workers
    for pid in workers:
        os.kill(pid, signal.SIGKILL)
    info = job.wait(timeout=300)
    assert info["status"] == "done" and info["attempts"] == 2 and "worker process died" in info["error"], info
    out = job.result()
    one = dynamics.simulate(planar3(), inputs["q0"][399], inputs["v0"], 1.0,
                            torque=PD(inputs["torque"]["q_target"][399], 50.0, 5.0),
                            **{k: v for k, v in LONG.items() if k != "duration"})
    assert np.array_equal(out["q"][399], one.q)


def test_expiry_removes_finished_jobs_and_stale_temporary_files(tmp_path):
    """In-process (no server): the housekeeping of service.jobs.executor on a store of its own."""
    settings = Settings(store_dir=tmp_path, job_expiry=0.0)
    files = JobFiles.under(tmp_path)
    db = JobDB(files.db)
    write_npz(files.inputs("old"), {"q": np.zeros((1, 2))})
    db.create("old", "", "planar-2r", "mass_matrix", {"options": {}}, 1, 10)
    db.create("queued", "", "planar-2r", "mass_matrix", {"options": {}}, 1, 10)
    db.cancel("old")
    stale, fresh = files.root / "parts" / ".a.npz.1.tmp", files.root / "results" / ".b.npz.2.tmp"
    orphan = files.inputs("no-such-job")  # (issue 25 A1: a failed submit's inputs, left by an older version)
    kept = files.inputs("queued")  # an old job's own inputs stay
    for path in (stale, fresh, orphan, kept):
        path.write_bytes(b"x")
    for path in (stale, orphan, kept):
        os.utime(path, (0, 0))
    executor = Executor(files, db, settings)
    time.sleep(0.01)
    executor.expire()
    assert db.get("old") is None and not files.inputs("old").exists()
    assert db.get("queued").status == "queued"  # an active job never expires
    assert not stale.exists() and fresh.exists() and not orphan.exists()
    assert kept.exists()
    executor.close()


def test_a_server_stopped_mid_job_leaks_no_semaphore(tmp_path):
    """Issue 25 D16: stopping the server left the job pool's semaphores to the resource tracker ("leaked
    semaphore objects to clean up at shutdown")."""
    server = Server(tmp_path / "store", env=KEYS).start()
    try:
        job = Client(server.url, api_key="alice-key").submit("planar_3r", "simulate_many", long_inputs(2000), LONG)
        wait_for(job, lambda i: i["status"] == "running")
    finally:
        server.stop()
    assert server.proc.returncode == 0 or server.proc.returncode is not None
    log = server.log.read_text()
    assert "leaked semaphore" not in log and "Traceback" not in log, log[-3000:]


def test_non_finite_inputs_are_refused_at_submission(alice, server):
    """Issue 49, finding 7: a job whose inputs held NaN was accepted (202) and failed once it ran, while the same
    input to the synchronous route is a 422. Now a 422 at submission, naming the input and its row, JSON or
    .npz, states or a torque's arrays; nothing is stored."""
    before = set((server.store / "jobs" / "inputs").iterdir())
    headers = {"Authorization": "Bearer alice-key"}
    body = ('{"robot": "planar_2r", "kind": "inverse_dynamics", "inputs": {"q": [[0, 0], [0, NaN]], '
            '"v": [[0, 0], [0, 0]], "a": [[0, 0], [0, 0]]}}')
    r = httpx.post(server.url + "/v1/jobs", content=body, headers={**headers, "Content-Type": "application/json"})
    assert r.status_code == 422 and r.json()["field"] == "inputs.q", r.text
    assert "non-finite" in r.json()["detail"] and "row 1" in r.json()["detail"]
    q = np.zeros((3, 3))
    q[2, 1] = np.inf
    cases = [({"q": np.zeros((3, 2)), "v": np.zeros((3, 2)), "a": q[:, :2]}, "inverse_dynamics", None, "inputs.a"),
             ({"q0": np.zeros((2, 3)), "v0": np.array([0.0, np.nan, 0.0])}, "simulate_many", {"duration": 0.1},
              "inputs.v0"),
             ({"q0": np.zeros((3, 3)), "v0": np.zeros(3), "torque": {"type": "pd", "q_target": q, "kp": 1.0,
                                                                      "kd": 1.0}},
              "simulate_many", {"duration": 0.1}, "inputs.torque.q_target")]
    for inputs, kind, options, field in cases:
        robot = "planar_2r" if kind == "inverse_dynamics" else "planar_3r"
        with pytest.raises(ServiceError) as e:
            alice.submit(robot, kind, inputs, options)
        assert (e.value.status, e.value.field) == (422, field), e.value.message
    assert set((server.store / "jobs" / "inputs").iterdir()) <= before


def test_the_job_database_is_private(tmp_path):
    """Issue 49, finding 8: jobs.db and its WAL and SHM files were created 0644 (readable by every user) while the
    robot files are 0600. Created 0600, and an older store's files are tightened when a server opens them."""
    old = os.umask(0o022)
    try:
        files = JobFiles.under(tmp_path)
        db = JobDB(files.db)
        db.create("a", "", "planar_2r", "mass_matrix", {"options": {}}, 1, 10)
        paths = [files.db, files.db.with_name("jobs.db-wal"), files.db.with_name("jobs.db-shm")]
        assert all(p.exists() for p in paths)
        assert {p.name: oct(p.stat().st_mode & 0o777) for p in paths} == {p.name: "0o600" for p in paths}
        db.close()
        for p in paths:
            if p.exists():
                p.chmod(0o644)  # (a store written by an older version)
        JobDB(files.db).close()
        assert {p.name: oct(p.stat().st_mode & 0o777) for p in paths if p.exists()} == \
            {p.name: "0o600" for p in paths if p.exists()}
    finally:
        os.umask(old)
