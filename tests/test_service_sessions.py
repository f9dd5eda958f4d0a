"""``/v1/sessions``: the library's Simulator stepped over a WebSocket (issue 47, "over the network").

Real numbers: a session's states are the library's Simulator's, bit for bit, for the same inputs (one environment
and a batch, a PD source, contact, reset and state/set_state). Bad input: a wrong-size or NaN torque, a step after a
failure, an unknown or deleted robot, a connection dropped mid-step, a flood of sessions from one key, an idle
session, no API key, a session too large: each a clear error frame (the HTTP API's code, status and field), and
nothing leaked (``GET /v1/sessions`` lists no session once the connections have closed).
"""

from __future__ import annotations

import json
import socket
import struct
import threading
import time
import warnings
from contextlib import ExitStack

import httpx
import numpy as np
import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

import dynamics
from robots import erd
from service.client import Client, ServiceError, SimulationWarning
from service_fixtures import ROBOTS, Server

PANDA_Q0 = np.array([0.1, -0.4, 0.2, -2.0, 0.1, 1.6, 0.7, 0.02, 0.02])
LIMIT = 4  # DYNAMICS_MAX_SESSIONS_PER_KEY of the main server
BALL = ('<robot name="session-ball"><link name="ball"><inertial><mass value="1"/><inertia ixx="0.004" iyy="0.004" '
        'izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial><collision><geometry><sphere radius="0.1"/></geometry>'
        '</collision></link></robot>')


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """No keys, LIMIT sessions, no simulation workers (sessions do not use them)."""
    s = Server(tmp_path_factory.mktemp("sessions") / "store",
               env={"DYNAMICS_MAX_SESSIONS_PER_KEY": str(LIMIT), "DYNAMICS_SIM_WORKERS": "0",
                    "DYNAMICS_MAX_SESSION_BYTES": str(64 * 1024 * 1024)}).start()
    yield s
    s.stop()


@pytest.fixture(scope="module")
def keyed(tmp_path_factory):
    """Two API keys, 2 sessions per key, a 3 s idle timeout."""
    s = Server(tmp_path_factory.mktemp("sessions-keyed") / "store",
               env={"DYNAMICS_API_KEYS": "k1,k2", "DYNAMICS_MAX_SESSIONS_PER_KEY": "2", "DYNAMICS_SIM_WORKERS": "0",
                    "DYNAMICS_SESSION_IDLE_TIMEOUT": "3"}).start()
    yield s
    s.stop()


@pytest.fixture(scope="module")
def client(server):
    with Client(server.url, timeout=120) as c:
        yield c


@pytest.fixture(scope="module")
def panda(client):
    path = erd("panda_description/urdf/panda.urdf")
    model = dynamics.load_urdf(path, mimic="independent")
    return client.upload(path, name="panda", mimic="independent"), model


def ws_url(server) -> str:
    return server.url.replace("http://", "ws://") + "/v1/sessions"


def listed(server, key=None) -> list:
    headers = {"Authorization": f"Bearer {key}"} if key else {}
    return httpx.get(server.url + "/v1/sessions", headers=headers).json()["sessions"]


def eventually_empty(server, key=None, timeout=30.0) -> None:
    """The registry lists no session (the server frees a session once it sees its connection gone)."""
    end = time.monotonic() + timeout
    while listed(server, key) and time.monotonic() < end:
        time.sleep(0.05)
    assert listed(server, key) == []


def create(ws, **fields):
    ws.send(json.dumps({"type": "create", "robot": "planar_2r", "q0": [0.3, -0.2], "v0": [0.0, 0.0], "dt": 0.01,
                        "integrator": "rk4", **fields}))
    return json.loads(ws.recv(timeout=60))


def refused(ws) -> dict:
    """The error frame of a refused connection, then the close code 4000 + its status."""
    frame = json.loads(ws.recv(timeout=60))
    with pytest.raises(ConnectionClosed) as e:
        ws.recv(timeout=60)
    assert e.value.rcvd.code == 4000 + frame["status"]
    return frame


# -- real numbers -----------------------------------------------------------------------------------------------
def test_a_panda_session_is_the_library_bit_for_bit(server, panda):
    robot, model = panda
    pd = dynamics.torques.PD(kp=50.0, kd=5.0, q_target=PANDA_Q0 + 0.2)
    v0 = np.linspace(-0.3, 0.3, model.nv)
    rng = np.random.default_rng(4)
    for integrator in ("rk4", "auto", "implicit_euler"):
        here = dynamics.Simulator(model, PANDA_Q0, v0, dt=1e-3, torque=pd, integrator=integrator)
        with robot.simulator(PANDA_Q0, v0, dt=1e-3, torque=pd, integrator=integrator) as sim:
            assert (sim.n, sim.nq, sim.nv, sim.batched, sim.joint_names) == (1, 9, 9, False, model.joint_names)
            assert sim.t == 0.0 and np.array_equal(sim.q, PANDA_Q0) and np.array_equal(sim.v, v0)
            for k in range(40):
                tau = None if k % 3 == 0 else rng.normal(size=model.nv)
                here.step(tau)
                sim.step(tau)
                assert sim.t == here.t and np.array_equal(sim.q, here.q) and np.array_equal(sim.v, here.v)
            assert not sim.failed and sim.status == "ok"
            assert np.array_equal(sim.state(), here.state())
            x = sim.state()
            for s in (sim, here):
                s.step(np.ones(model.nv))
                s.set_state(x)
                s.step()
            assert np.array_equal(sim.state(), here.state())
            for s in (sim, here):
                s.reset(PANDA_Q0 - 0.1, np.zeros(model.nv), t=2.0)
                s.step()
            assert sim.t == here.t and np.array_equal(sim.q, here.q) and np.array_equal(sim.v, here.v)
            assert sim.stats["steps"] == here.stats["steps"]
            if integrator == "auto":
                assert sim.error == here.error
            else:
                assert np.isnan(sim.error)
    eventually_empty(server)


def test_a_batch_session_is_the_library_bit_for_bit(server, panda):
    robot, model = panda
    rng = np.random.default_rng(5)
    Q0 = PANDA_Q0 + 0.1 * rng.normal(size=(3, model.nq))
    here = dynamics.Simulator(model, Q0, np.zeros(model.nv), dt=2e-3, integrator="rk4", substep=5e-4)
    with robot.simulator(Q0, np.zeros(model.nv), dt=2e-3, integrator="rk4", substep=5e-4) as sim:
        assert (sim.n, sim.batched) == (3, True)
        for k in range(20):
            tau = rng.normal(size=(3, model.nv)) if k % 2 else rng.normal(size=model.nv)  # (n, nv) or shared
            here.step(tau)
            sim.step(tau)
            assert np.array_equal(sim.t, here.t) and np.array_equal(sim.q, here.q) and np.array_equal(sim.v, here.v)
        for s in (sim, here):
            s.reset(which=[1])
            s.step()
        assert np.array_equal(sim.state(), here.state())
        assert sim.failed.tolist() == [False] * 3 and sim.status == ["ok"] * 3
    # n copies of one q0: a batch
    with robot.simulator(PANDA_Q0, np.zeros(model.nv), dt=1e-3, integrator="euler", n=2) as sim:
        sim.step()
        assert sim.batched and sim.q.shape == (2, 9) and np.array_equal(sim.q[0], sim.q[1])
    eventually_empty(server)


def test_contact_and_its_forces_are_the_library(server, client):
    ball = client.upload(BALL.encode(), name="session-ball", floating_base=True)
    model = dynamics.load_urdf(BALL, floating_base=True, collision=True)  # (as the service reads a URDF)
    q0 = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0, 1.0])
    contact = dynamics.Contact(friction=0.5)
    here = dynamics.Simulator(model, q0, np.zeros(6), dt=2e-3, contact=contact, integrator="rk4", substep=1e-4)
    with ball.simulator(q0, np.zeros(6), dt=2e-3, contact=contact, integrator="rk4", substep=1e-4) as sim:
        for _ in range(60):
            here.step()
            sim.step()
        assert np.array_equal(sim.q, here.q) and np.array_equal(sim.v, here.v)
        f, details = sim.contact_forces(details=True)
        f_here, details_here = here.contact_forces(details=True)
        assert np.array_equal(f, f_here) and details["pairs"] == [list(p) for p in details_here.pairs]
        assert np.array_equal(details["normal_force"], details_here.normal_force)
        assert details["normal_force"][0] > 0  # resting on the ground
    with client.robot("planar_2r").simulator([0.3, -0.2], [0.0, 0.0], dt=0.01) as plain:
        with pytest.raises(ServiceError) as e:
            plain.contact_forces()
        assert e.value.status == 422 and "no contact" in e.value.message
        plain.step()  # the session goes on
    eventually_empty(server)


# -- bad input --------------------------------------------------------------------------------------------------
def test_bad_frames_are_clear_errors_and_the_session_goes_on(server):
    with connect(ws_url(server), compression=None) as ws:
        hello = create(ws)
        assert hello["type"] == "created" and (hello["nq"], hello["nv"], hello["n"]) == (2, 2, 1)
        assert hello["layout"]["answer"] == [["t", [1]], ["q", [1, 2]], ["v", [1, 2]], ["failed", [1]]]
        bad = [(b"\x00" * 12, "tau", "16 bytes"),  # a wrong-size binary frame
               (struct.pack("<2d", float("nan"), 0.0), "tau", "joint 'joint1') is nan"),
               (struct.pack("<2d", 0.0, float("inf")), "tau", "is inf"),
               ("not json", "message", "not JSON"),
               ('[1, 2]', "message", "expected a JSON object"),
               ('{"type": "jump"}', "type", "expected one of"),
               ('{"type": "create", "robot": "planar_2r"}', "type", "one per connection"),
               ('{"type": "reset", "q": [1, 2, 3]}', "q", "expected shape"),
               ('{"type": "reset", "q": "abc"}', "q", "expected a number"),
               ('{"type": "reset", "velocity": [0, 0]}', "velocity", "unknown field"),
               ('{"type": "set_state", "x": [1, 2]}', "x", "expected shape"),
               ('{"type": "reset", "which": [5]}', "which", "indices in [0, 1)"),
               ('{"type": "contact_forces", "env": -1}', "env", "greater than or equal to 0"),
               ('{"type": "contact_forces"}', "contact_forces", "no contact")]
        for message, field, words in bad:
            ws.send(message)
            frame = json.loads(ws.recv(timeout=60))
            assert (frame["error"], frame["status"], frame["field"]) == ("invalid_input", 422, field), frame
            assert words in frame["detail"], frame
        ws.send(struct.pack("<2d", 1.0, 2.0))  # still alive
        t, q1, q2, v1, v2, failed = np.frombuffer(ws.recv(timeout=60), dtype="<f8")
        assert t == pytest.approx(0.01) and failed == 0.0
        ws.send(b"")  # zero torque
        assert np.frombuffer(ws.recv(timeout=60), dtype="<f8")[0] == pytest.approx(0.02)
    eventually_empty(server)


def test_bad_create_messages_close_the_connection(server, client):
    cases = [({"robot": "no_such_robot"}, 404, "not_found", "robot", "bundled robots are"),
             ({"q0": [0.3]}, 422, "invalid_input", "q0", "expected shape"),
             ({"dt": -1}, 422, "invalid_input", "dt", "greater than 0"),
             ({"integrator": "leapfrog"}, 422, "invalid_input", "integrator", "rk4"),
             ({"torque": {"type": "pd", "q_target": [0, 0], "kp": 5}}, 422, "invalid_input", "torque.pd.kd", "missing"),
             ({"torque": {"type": "pd", "q_target": [0, 0, 0], "kp": 5, "kd": 1}}, 422, "invalid_input",
              "torque.q_target", "shape"),
             ({"contact": {"geometries": [{"type": "sphere", "frame": "nowhere", "radius": 0.1}]}}, 422,
              "invalid_input", "contact.geometries[0].frame", "no frame named"),
             ({"q0": [[0.0, 0.0]] * 300_000}, 422, "invalid_input", "q0", "DYNAMICS_MAX_BATCH"),
             ({"n": 100_000}, 413, "too_large", "n", "DYNAMICS_MAX_SESSION_BYTES")]
    for fields, status, code, field, words in cases:
        with connect(ws_url(server), compression=None, max_size=None) as ws:
            ws.send(json.dumps({"type": "create", "robot": "planar_2r", "q0": [0.3, -0.2], "v0": [0.0, 0.0],
                                "dt": 0.01, "integrator": "rk4", **fields}))
            frame = refused(ws)
            assert (frame["status"], frame["error"], frame["field"]) == (status, code, field), frame
            assert words in frame["detail"], frame
    for first in (b"\x00" * 16, "{}", '{"type": "step"}'):
        with connect(ws_url(server)) as ws:
            ws.send(first)
            assert refused(ws)["status"] == 422
    with pytest.raises(ServiceError) as e:
        client.robot("planar_2r").simulator([0.3, -0.2, 0.1], [0.0, 0.0], dt=0.01)
    assert e.value.status == 422 and e.value.field == "q0"
    eventually_empty(server)


def test_a_step_after_a_failure(server, client):
    robot = client.robot("planar_2r")
    with robot.simulator([0.3, -0.2], [0.0, 0.0], dt=0.01, integrator="euler") as sim:
        with pytest.warns(SimulationWarning, match="velocity exceeded"):
            sim.step([1e12, 0.0])
        assert sim.failed and sim.t == 0.0 and "failed" in sim.status
        with pytest.raises(ServiceError) as e:
            sim.step()
        assert e.value.status == 422 and "reset" in e.value.message
        sim.reset()
        sim.step()
        assert not sim.failed and sim.t == pytest.approx(0.01)
    with robot.simulator([[0.3, -0.2], [0.1, 0.1]], [0.0, 0.0], dt=0.01, integrator="euler") as sim:
        with pytest.warns(SimulationWarning, match="environment 1"):
            sim.step([[0.0, 0.0], [1e12, 0.0]])
        assert sim.failed.tolist() == [False, True]
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            sim.step()  # the failed one waits, the other goes on
        assert sim.t[0] == pytest.approx(0.02) and sim.t[1] == 0.0
        sim.reset(which=[1])
        assert sim.failed.tolist() == [False, False]
    eventually_empty(server)


def test_a_deleted_robot(server, client):
    robot = client.upload((ROBOTS / "planar_3r.urdf").read_text(), name="doomed")
    with robot.simulator(np.zeros(3), np.zeros(3), dt=0.01) as sim:
        client.delete(robot.id)
        sim.step()  # a session keeps the model it was made with
        assert sim.t == pytest.approx(0.01)
    with pytest.raises(ServiceError) as e:
        robot.simulator(np.zeros(3), np.zeros(3), dt=0.01)
    assert e.value.status == 404 and e.value.code == "not_found" and e.value.field == "robot"
    eventually_empty(server)


def test_a_connection_dropped_mid_step_frees_its_session(server, panda):
    robot, model = panda
    n = 800  # a step of 20 substeps of 800 environments, ~0.1 s: it runs in a thread while the client leaves
    for _ in range(3):
        ws = connect(ws_url(server), compression=None, max_size=None).__enter__()
        hello = create(ws, robot=robot.id, q0=[PANDA_Q0.tolist()] * n, v0=[0.0] * 9, dt=2e-2, integrator="rk4",
                       substep=1e-3)
        assert hello["n"] == n and len(listed(server)) == 1
        ws.send(b"")  # the first step
        ws.recv(timeout=120)
        ws.send(b"")  # then gone mid-step: no close frame, the socket shut
        ws.socket.shutdown(socket.SHUT_RDWR)
        ws.socket.close()
        eventually_empty(server)
    assert httpx.get(server.url + "/v1/health").status_code == 200


def test_a_flood_of_sessions_from_one_key_is_refused_and_nothing_leaks(server):
    with ExitStack() as stack:
        held = [stack.enter_context(connect(ws_url(server))) for _ in range(LIMIT)]
        for ws in held[:2]:
            create(ws)
        rss = server.rss_kib()
        started = time.monotonic()
        for k in range(1000):
            with connect(ws_url(server)) as ws:
                frame = refused(ws)
                assert (frame["status"], frame["error"], frame["field"]) == (429, "too_many_sessions", "sessions")
                assert "DYNAMICS_MAX_SESSIONS_PER_KEY" in frame["detail"]
        assert len(listed(server)) == LIMIT
        assert server.rss_kib() < rss + 20 * 1024, "1000 refusals should hold no memory"
        print(f"1000 refusals in {time.monotonic() - started:.2f} s")
        for ws in held[:2]:  # the sessions held meanwhile are intact
            ws.send(b"")
            assert len(ws.recv(timeout=60)) == 8 * 6
    eventually_empty(server)


def test_api_keys_idle_timeout_and_sessions_per_key(keyed):
    for headers, words in (({}, "missing"), ({"Authorization": "Bearer nope"}, "valid")):
        with connect(ws_url(keyed), additional_headers=headers) as ws:
            frame = refused(ws)
            assert (frame["status"], frame["error"], frame["field"]) == (401, "unauthorized", "Authorization")
            assert words in frame["detail"]
    with Client(keyed.url, api_key="k1") as c1, Client(keyed.url, api_key="k2") as c2:
        a = c1.robot("planar_2r").simulator([0.3, -0.2], [0.0, 0.0], dt=0.01)
        b = c1.robot("planar_2r").simulator([0.3, -0.2], [0.0, 0.0], dt=0.01)
        with pytest.raises(ServiceError) as e:  # the third of key 1
            c1.robot("planar_2r").simulator([0.3, -0.2], [0.0, 0.0], dt=0.01)
        assert e.value.status == 429 or "4429" in e.value.message
        with c2.robot("planar_2r").simulator([0.3, -0.2], [0.0, 0.0], dt=0.01) as other:  # key 2's own count
            other.step()
            assert [s["session"] for s in listed(keyed, "k2")] == [other.session]
        assert {s["session"] for s in listed(keyed, "k1")} == {a.session, b.session}
        a.close()
        b.close()
        b.close()  # idempotent
        eventually_empty(keyed, "k1")
        idle = c1.robot("planar_2r").simulator([0.3, -0.2], [0.0, 0.0], dt=0.01)
        idle.step()
        time.sleep(4.5)  # past the idle timeout (3 s)
        with pytest.raises(ServiceError) as e:
            idle.step()
        assert e.value.code in ("idle_timeout", "closed") and ("DYNAMICS_SESSION_IDLE_TIMEOUT" in e.value.message
                                                               or "4408" in e.value.message)
        with pytest.raises(ServiceError) as e:
            idle.step()
        assert e.value.code == "closed"
    eventually_empty(keyed, "k1")
    eventually_empty(keyed, "k2")


def test_the_client_object(server, client):
    robot = client.robot("planar_2r")
    sim = robot.simulator([0.3, -0.2], [0.0, 0.0], dt=0.01, integrator="rk4",
                          torque={"type": "pd", "q_target": [0.5, 0.5], "kp": 50.0, "kd": 4.0})
    assert "planar_2r" in repr(sim) and sim.q.flags.writeable is False
    with pytest.raises(ValueError, match=r"tau: expected shape \(2,\)"):
        sim.step([1.0, 2.0, 3.0])
    sim.step()
    sim.close()
    with pytest.raises(ServiceError) as e:
        sim.step()
    assert e.value.code == "closed"
    eventually_empty(server)


def test_many_sessions_at_once(server, client):
    """LIMIT sessions stepped from LIMIT threads at once: each its own numbers."""
    model = dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf"))
    results, errors = {}, []

    def run(k):
        try:
            q0 = [0.1 * k, -0.2]
            with client.robot("planar_2r").simulator(q0, [0.0, 0.0], dt=0.01, integrator="rk4") as sim:
                for _ in range(50):
                    sim.step([0.1 * k, 0.0])
                results[k] = sim.q.copy()
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=run, args=(k,)) for k in range(LIMIT)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors, errors
    for k in range(LIMIT):
        here = dynamics.Simulator(model, [0.1 * k, -0.2], [0.0, 0.0], dt=0.01, integrator="rk4")
        for _ in range(50):
            here.step([0.1 * k, 0.0])
        assert np.array_equal(results[k], here.q)
    eventually_empty(server)


def test_a_session_of_a_reduced_model(server, client):
    model = dynamics.lock_joints(dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf")), {"joint2": 0.3})
    here = dynamics.Simulator(model, [0.2], [0.0], dt=0.01, integrator="rk4")
    with client.robot("planar_2r").simulator([0.2], [0.0], dt=0.01, integrator="rk4", locked={"joint2": 0.3}) as sim:
        assert (sim.nq, sim.nv, sim.joint_names) == (1, 1, ("joint1",))
        assert sim.info["scene"]["locked"] == {"joint2": 0.3}
        for _ in range(10):
            sim.step([0.5])
            here.step([0.5])
        assert np.array_equal(sim.q, here.q) and np.array_equal(sim.v, here.v)
    eventually_empty(server)
