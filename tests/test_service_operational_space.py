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


def test_the_worker_answers_a_bad_spec_422_and_a_run_past_its_deadline_504():
    """In the worker: a bad operational-space spec is the library's input error (422, naming the frame); a run
    still going at its deadline is stopped by the C++ core and comes back as ``deadline`` (the server's 504),
    not as a failure (500)."""
    import time
    from types import SimpleNamespace

    from service.client import torque_spec
    from service.compute import Budget, Compute
    from service.errors import BudgetExceeded
    from service.sim import worker
    from service.sim.job import Job

    spec = torque_spec(Target("tip", [1.2, 0.0, 0.9], kp=1.0, kd=1.0, rows=[0, 2]))  # as the schema passes it
    urdf = (ROBOTS / "planar_2r.urdf").read_text()
    q0, v0 = np.array([0.3, 0.6]), np.zeros(2)
    bad = worker.handle(Job("arm", urdf, False, (), q0, v0, 0.1, {}, {**spec, "frame": "tpi"}, 1000,
                            deadline=time.monotonic() + 60.0), worker.ModelCache(2))
    assert bad.input_error and "tpi" in bad.input_error
    # 1e6 fixed steps (seconds of work) within 0.2 s
    long = Job("arm", urdf, False, (), q0, v0, 100.0, {"integrator": "rk4", "dt": 1e-4, "sample_dt": 1.0}, spec,
               1_000_000, deadline=time.monotonic() + 0.2)
    tic = time.monotonic()
    out = worker.handle(long, worker.ModelCache(2))
    assert time.monotonic() - tic < 1.0
    assert out.deadline and "deadline" in out.error and out.trajectory is None
    pool = SimpleNamespace(run=lambda job, deadline: out)
    with pytest.raises(BudgetExceeded):
        Compute._simulate(SimpleNamespace(pool=pool), long, Budget.starting_now(0.2))
