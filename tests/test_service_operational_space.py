"""Simulate over HTTP with the operational-space torque (issue 9, section 3): the same trajectory as the library,
and bad specs answered 422 naming the field."""

from __future__ import annotations

import numpy as np
import pytest

import dynamics
from dynamics.torques import OperationalSpace, TaskReference, Target
from service.client import Client, ServiceError
from service_fixtures import ROBOTS, shared_server, while_simulation_starts


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    with Client(shared_server(tmp_path_factory.getbasetemp()).url) as c:
        yield c


def test_operational_space_over_http_matches_the_library(client):
    robot = client.robot("planar-2r")
    model = dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf"))
    q0, v0 = np.array([0.3, 0.6]), np.zeros(2)
    while_simulation_starts(lambda: robot.simulate(q0, v0, 0.01))
    kw = dict(sample_dt=0.1)
    target = {"type": "operational_space", "frame": "tip", "position": [1.2, 0.0, 0.9], "kp": 100.0, "kd": 20.0,
              "rows": [0, 2]}
    # the worker compiles the operational-space source after it says ready: 503 until then
    traj = while_simulation_starts(lambda: robot.simulate(q0, v0, 1.0, torque=target, **kw))
    lib = dynamics.simulate(model, q0, v0, 1.0, torque=Target("tip", [1.2, 0.0, 0.9], kp=100.0, kd=20.0,
                                                              rows=[0, 2]), **kw)
    assert traj.report["status"] == "ok" and np.array_equal(traj.q, lib.q) and np.array_equal(traj.tau, lib.tau)
    t = np.linspace(0.0, 1.0, 11)
    p = dynamics.frame_placement(model, q0, "tip")[:3, 3] + np.outer(t, [0.1, 0.0, 0.05])
    path = {"type": "operational_space", "frame": "tip", "reference": {"t": t, "position": p}, "kp": [100.0, 50.0],
            "kd": 20.0, "rows": [0, 2]}
    traj = robot.simulate(q0, v0, 1.0, torque=path, **kw)
    lib = dynamics.simulate(model, q0, v0, 1.0, torque=OperationalSpace("tip", TaskReference(t, p), [100.0, 50.0],
                                                                        20.0, rows=[0, 2]), **kw)
    assert np.array_equal(traj.q, lib.q)


@pytest.mark.parametrize("change, field", [
    ({"kp": -1.0}, "torque.kp"),
    ({"frame": "tpi"}, "torque.frame"),
    ({"position": [1.0, 2.0]}, "torque.position"),
    ({"reference": {"t": [0.0, 1.0], "position": [[1.0, 0, 0.5]]}}, "torque.reference"),
    ({"position": None, "reference": {"t": [0.0, 1.0], "position": [[1.0, 0, 0.5]]}}, "torque.reference.position"),
    ({"rows": [0, 5]}, "torque.rows"),
])
def test_bad_operational_space_specs_name_the_field(client, change, field):
    robot = client.robot("planar-2r")
    spec = {"type": "operational_space", "frame": "tip", "position": [1.2, 0.0, 0.9], "kp": 1.0, "kd": 1.0,
            "rows": [0, 2], **change}
    with pytest.raises(ServiceError) as e:
        robot.simulate([0.3, 0.6], [0.0, 0.0], 0.1, torque=spec)
    assert e.value.status == 422 and e.value.field == field, e.value.message


def test_client_sends_the_library_operational_space_objects(client):
    """The client turns Target / OperationalSpace (with a TaskReference inside) into the HTTP spec, and the server
    answers with the same trajectory as the library given the objects."""
    from service.client import torque_spec
    target = Target("tip", np.array([1.2, 0.0, 0.9]), kp=100.0, kd=20.0, rows=[0, 2])
    assert torque_spec(target) == {"type": "operational_space", "frame": "tip", "position": [1.2, 0.0, 0.9],
                                   "kp": 100.0, "kd": 20.0, "posture_kp": 0.0, "rows": [0, 2], "damping": 0.0}
    robot = client.robot("planar-2r")
    model = dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf"))
    q0, v0 = np.array([0.3, 0.6]), np.zeros(2)
    t = np.linspace(0.0, 1.0, 11)
    p = dynamics.frame_placement(model, q0, "tip")[:3, 3] + np.outer(t, [0.1, 0.0, 0.05])
    path = OperationalSpace("tip", TaskReference(t, p), [100.0, 50.0], 20.0, rows=[0, 2])
    assert torque_spec(path)["reference"] == {"t": t.tolist(), "position": p.tolist()}
    traj = while_simulation_starts(lambda: robot.simulate(q0, v0, 1.0, torque=path, sample_dt=0.1))
    lib = dynamics.simulate(model, q0, v0, 1.0, torque=path, sample_dt=0.1)
    assert np.array_equal(traj.q, lib.q) and np.array_equal(traj.tau, lib.tau)


def test_a_request_for_a_source_still_compiling_gets_503_saying_how_long(monkeypatch):
    """The worker compiles the operational-space source after it says ready (its own problem type); a request that
    needs it meanwhile waits until its deadline (less a second), then is answered 503 with the time left; a bad
    spec is still a 422 at once."""
    import time
    from types import SimpleNamespace

    from service.compute import Budget, Compute
    from service.errors import Unavailable
    from service.sim import warm, worker
    from service.sim.job import Job, Outcome

    later = warm.LateWarmup()  # never started: still compiling
    monkeypatch.setattr(warm, "LATER", later)
    from service.client import torque_spec
    spec = torque_spec(Target("tip", [1.2, 0.0, 0.9], kp=1.0, kd=1.0, rows=[0, 2]))  # as the schema passes it
    urdf = (ROBOTS / "planar_2r.urdf").read_text()
    job = Job("arm", urdf, False, (), np.array([0.3, 0.6]), np.zeros(2), 0.1, {}, spec, 1000,
              deadline=time.monotonic() + 1.5)
    tic = time.monotonic()
    out = worker.handle(job, worker.ModelCache(2))
    assert 0.4 < time.monotonic() - tic < 1.4  # waited until the deadline less a second
    assert out.unavailable and "operational-space" in out.unavailable and "s left" in out.unavailable
    assert 1.0 <= out.retry_after <= later.SECONDS
    bad = worker.handle(Job("arm", urdf, False, (), np.array([0.3, 0.6]), np.zeros(2), 0.1, {},
                            {**spec, "frame": "tpi"}, 1000, deadline=time.monotonic() + 60.0),
                        worker.ModelCache(2))
    assert bad.input_error and "tpi" in bad.input_error

    pool = SimpleNamespace(run=lambda job, deadline: out)
    with pytest.raises(Unavailable) as e:
        Compute._simulate(SimpleNamespace(pool=pool), job, Budget.starting_now(10.0))
    assert "still compiling the simulation kernels of the operational-space" in str(e.value) and e.value.headers["Retry-After"].isdigit()
    assert isinstance(out, Outcome)
