"""``sensitivities`` in ``POST /v1/robots/{id}/simulate``: the library's numbers through the service (JSON and
.npz, the client), the column names, a bad name as a 422 naming the field, and the answer-size limit counting
the sensitivities (a 413 before any work)."""

from __future__ import annotations

import httpx
import numpy as np
import pytest

import dynamics
from dynamics.torques import PD
from service.client import Client, ServiceError
from service_fixtures import ROBOTS, shared_server, while_simulation_starts

Q0, V0 = [0.3, 0.2], [0.0, 1.5]
PD_SPEC = {"type": "pd", "q_target": [0.5, -0.3], "kp": 8.0, "kd": 0.5}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    return shared_server(tmp_path_factory.getbasetemp())


@pytest.fixture(scope="module")
def client(server):
    with Client(server.url, timeout=300) as c:
        yield c


def test_client_gets_the_library_numbers(client):
    robot = client.robot("planar-2r")
    traj = while_simulation_starts(lambda: robot.simulate(Q0, V0, 0.5, torque=PD_SPEC, integrator="rk45",
                                                          sample_dt=0.05, sensitivities=("x0", "kp")))
    model = dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf"))
    ref = dynamics.simulate(model, Q0, V0, 0.5, torque=PD([0.5, -0.3], 8.0, 0.5), integrator="rk45", sample_dt=0.05,
                            sensitivities=("x0", "kp"))
    assert traj.sensitivities.shape == ref.sensitivities.shape == (len(ref.t), 4, 6)
    assert np.array_equal(traj.sensitivities, ref.sensitivities)
    assert traj.report["sensitivities"]["columns"] == ref.report["sensitivities"]["columns"]
    assert traj.report["sensitivities"]["error_estimate"] == ref.report["sensitivities"]["error_estimate"]
    plain = robot.simulate(Q0, V0, 0.5, torque=PD_SPEC, integrator="rk45", sample_dt=0.05)
    assert plain.sensitivities is None and "sensitivities" not in plain.report


def test_json_answer_and_bad_names(server, client):
    while_simulation_starts(lambda: client.robot("planar-2r").simulate(Q0, V0, 0.01))
    url = f"{server.url}/v1/robots/planar-2r/simulate"
    body = {"q0": Q0, "v0": V0, "duration": 0.2, "sample_dt": 0.1, "integrator": "rk45", "torque": PD_SPEC}
    ans = httpx.post(url, json={**body, "sensitivities": True}, timeout=120).json()
    S = np.array(ans["sensitivities"])
    assert S.shape == (len(ans["t"]), 4, 4) and np.array_equal(S[0], np.eye(4))
    bad = httpx.post(url, json={**body, "sensitivities": ["x0", "gain"]}, timeout=120)
    assert bad.status_code == 422 and "sensitivities" in bad.json()["detail"]
    with pytest.raises(ServiceError) as e:
        client.robot("planar-2r").simulate(Q0, V0, 0.2, torque=PD_SPEC, sensitivities=["kp"], integrator="euler",
                                           dt=0.01)
    assert e.value.status == 422 and "euler" in e.value.message


def test_answer_size_counts_the_sensitivities(server):
    """puma560 under PD with x0 and every PD parameter: 12 x 42 numbers a sample, 100,001 samples: over the
    answer limit (refused before the run), where the same run without sensitivities (19 a sample) is not."""
    body = {"q0": [0.0] * 6, "v0": [0.0] * 6, "duration": 1.0, "sample_dt": 1e-5,
            "torque": {"type": "pd", "q_target": [0.1] * 6, "kp": 10.0, "kd": 1.0},
            "sensitivities": ["x0", "kp", "kd", "q_target", "v_target", "tau_ff"]}
    r = httpx.post(f"{server.url}/v1/robots/puma560/simulate", json=body, timeout=120,
                   headers={"Accept": "application/x-npz"})
    assert r.status_code == 413 and "answer" in r.json()["detail"], r.text


def test_simulate_many_job_returns_the_sensitivities(client):
    inputs = {"q0": np.array([Q0, [0.1, 0.4]]), "v0": np.array(V0), "torque": PD_SPEC}
    options = {"duration": 0.2, "integrator": "rk45", "sample_dt": 0.1, "sensitivities": ["x0", "kd"]}
    job = client.submit("planar-2r", "simulate_many", inputs, options)
    assert job.wait(timeout=300)["status"] == "done"
    out = job.result()
    model = dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf"))
    one = dynamics.simulate(model, [0.1, 0.4], V0, 0.2, torque=PD([0.5, -0.3], 8.0, 0.5), integrator="rk45",
                            sample_dt=0.1, sensitivities=("x0", "kd"))
    assert out["sensitivities"].shape == (2, len(one.t), 4, 6)
    assert np.array_equal(out["sensitivities"][1], one.sensitivities)
