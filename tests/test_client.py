"""The Python client against a real server: same names and shapes as the library, typed errors, simulation."""

from __future__ import annotations

import time

import httpx
import numpy as np
import pytest

import dynamics
from service.client import Client, ServiceError, Trajectory
from service_fixtures import ROBOTS, free_port, shared_server, while_simulation_starts


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    return shared_server(tmp_path_factory.getbasetemp())


@pytest.fixture(scope="module")
def client(server):
    with Client(server.url) as c:
        yield c


def test_upload_and_every_method_matches_the_library(client):
    path = ROBOTS / "planar_3r.urdf"
    robot = client.upload(path, name="three")
    assert client.upload(path.read_text(), name="three").id == robot.id  # same upload, same id
    assert client.robot(robot.id).joint_names == robot.joint_names
    model = dynamics.load_urdf(str(path))
    rng = np.random.default_rng(11)
    for shape in [(model.nq,), (7, model.nq)]:
        q, v, a = rng.normal(size=(3, *shape))
        g = np.array([0.0, -9.81, 0.0])
        assert np.array_equal(robot.inverse_dynamics(q, v, a), dynamics.inverse_dynamics(model, q, v, a))
        assert np.array_equal(robot.inverse_dynamics(q, v, a, gravity=g),
                              dynamics.inverse_dynamics(model, q, v, a, gravity=g))
        assert np.array_equal(robot.forward_dynamics(q, v, a), dynamics.forward_dynamics(model, q, v, a))
        assert np.array_equal(robot.mass_matrix(q), dynamics.mass_matrix(model, q))
        assert np.array_equal(robot.gravity_torques(q), dynamics.gravity_torques(model, q))
        assert np.array_equal(robot.bias_forces(q, v), dynamics.bias_forces(model, q, v))
        assert robot.mass_matrix(q).shape == shape[:-1] + (model.nv, model.nv)
    client.delete(robot.id)
    with pytest.raises(ServiceError) as e:
        client.robot(robot.id)
    assert e.value.status == 404


def test_big_batches_travel_as_npz(client):
    robot = client.robot("puma560")
    model = dynamics.load_urdf(str(ROBOTS / "puma560.urdf"))
    q, v, a = np.random.default_rng(2).normal(size=(3, 10_000, model.nq))
    assert q.size > client.npz_threshold
    assert np.array_equal(robot.inverse_dynamics(q, v, a), dynamics.inverse_dynamics(model, q, v, a))


def test_errors_are_typed(client, server):
    robot = client.robot("planar-2r")
    with pytest.raises(ServiceError) as e:
        robot.inverse_dynamics(np.zeros((4, 2)), np.zeros((4, 3)), np.zeros((4, 2)))
    assert e.value.status == 422 and e.value.field == "v" and "expected shape" in e.value.message
    with pytest.raises(ServiceError) as e:
        client.robot("no-such-robot")
    assert e.value.status == 404 and e.value.code == "not_found"
    with pytest.raises(ServiceError) as e:
        client.upload("<robot name='x'><link name='a'/><joint", name="broken")
    assert e.value.status == 422 and e.value.field == "urdf"
    with Client(f"http://127.0.0.1:{free_port()}", timeout=2) as nobody:
        with pytest.raises(ServiceError) as e:
            nobody.health()
        assert e.value.status == 0 and e.value.code == "unreachable"


def _wait_for_simulation(client, robot):
    return while_simulation_starts(lambda: robot.simulate([0.1, 0.2], [0.0, 0.0], 0.01))


def test_simulate(client):
    robot = client.robot("planar-2r")
    _wait_for_simulation(client, robot)
    q0, v0 = np.array([0.3, -0.2]), np.array([0.0, 0.5])
    kp, kd, target = np.array([50.0, 20.0]), 4.0, np.array([0.5, 0.5])
    traj = while_simulation_starts(lambda: robot.simulate(q0, v0, 0.5, sample_dt=0.05, torque={
        "type": "pd", "q_target": target, "kp": kp, "kd": kd}))
    assert isinstance(traj, Trajectory) and traj.report["status"] == "ok"
    assert traj.t.shape == (11,) and traj.q.shape == (11, 2) and traj.tau.shape == (11, 2)
    assert np.array_equal(traj.q[0], q0) and np.array_equal(traj.v[0], v0)
    # the recorded torques are the PD law at the recorded states
    assert np.allclose(traj.tau, kp * (target - traj.q) - kd * traj.v, atol=1e-9)
    again = robot.simulate(q0, v0, 0.5, torque={"type": "pd", "q_target": target, "kp": kp, "kd": kd},
                           sample_dt=0.05)
    assert np.array_equal(again.q, traj.q)  # deterministic
    raw = httpx.post(f"{client.base_url}/v1/robots/planar-2r/simulate", timeout=60, json={
        "q0": q0.tolist(), "v0": v0.tolist(), "duration": 0.5, "sample_dt": 0.05,
        "torque": {"type": "pd", "q_target": target.tolist(), "kp": kp.tolist(), "kd": kd}})
    assert raw.status_code == 200 and raw.headers["content-type"] == "application/json"
    assert np.array_equal(raw.json()["q"], traj.q) and raw.json()["report"]["status"] == "ok"  # JSON = .npz
    const = robot.simulate(q0, v0, 0.2, torque={"type": "constant", "tau": [1.0, -2.0]}, integrator="rk4",
                           dt=1e-3, sample_dt=0.1)
    assert np.array_equal(const.tau, np.tile([1.0, -2.0], (3, 1))) and const.report["integrator"] == "rk4"
    table = robot.simulate(q0, v0, 0.2, torque={"type": "table", "t": [0.0, 0.2], "tau": [[0, 0], [2, 4]]},
                           sample_dt=0.1)
    assert np.allclose(table.tau, [[0, 0], [1, 2], [2, 4]])
    for torque, field in [({"type": "pd", "q_target": target, "kp": [1, 2, 3], "kd": 1}, "torque.kp"),
                          ({"type": "warp"}, "torque.type")]:
        with pytest.raises(ServiceError) as e:
            robot.simulate(q0, v0, 0.1, torque=torque)
        assert e.value.status == 422 and e.value.field == field, e.value.message
    with pytest.raises(ServiceError) as e:
        robot.simulate(q0, v0, 100.0, integrator="euler", dt=1e-6)
    assert e.value.status == 422 and e.value.field == "dt"
    with pytest.raises(ServiceError) as e:
        robot.simulate(q0, v0, 100.0, sample_dt=1e-5)
    assert e.value.status == 422 and e.value.field == "sample_dt" and "DYNAMICS_MAX_SAMPLES" in e.value.message


def test_simulation_past_its_budget_is_stopped_by_the_core(server):
    """A simulation longer than the budget is answered 504 within a little of it: the C++ core checks the
    deadline in its loop and stops, so its worker process stays and takes the next job (no kill, no restart)."""
    with Client(server.url, time_budget=0.3) as c:
        robot = c.robot("puma560")
        _wait_for_simulation(c, c.robot("planar-2r"))
        pids_before = _worker_pids(server.proc.pid)
        t0 = time.monotonic()
        with pytest.raises(ServiceError) as e:
            robot.simulate(np.zeros(6), np.ones(6), 1000.0, rtol=1e-12, atol=1e-12, sample_dt=1.0)
        assert e.value.status == 504 and e.value.code == "time_budget_exceeded"
        assert time.monotonic() - t0 < 3.0
        assert _worker_pids(server.proc.pid) == pids_before
        _wait_for_simulation(c, c.robot("planar-2r"))


def _worker_pids(parent: int) -> list[int]:
    import os

    pids = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
                with open(f"/proc/{entry}/cmdline", "rb") as f:
                    cmd = f.read()
            except OSError:
                continue
            if int(fields[1]) == parent and b"service.sim.worker" in cmd:
                pids.append(int(entry))
    return pids
