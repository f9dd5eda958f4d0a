"""What a new user meets in the first hour (issue 25 C11, D13, D14, D16), in-process (FastAPI's TestClient; the
Python client is pointed at it): one robot name everywhere, one answer for floating_base, clear refusals."""

from __future__ import annotations

import re

import numpy as np
import pytest

import dynamics
from service.client import Client, ServiceError
from service_fixtures import in_process_app

#: a floating joint below the root: the model floats though the upload asked for no floating base
FLOATING_BELOW_ROOT = """<robot name="drone">
  <link name="world"/>
  <link name="body"><inertial><mass value="1"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="free" type="floating"><parent link="world"/><child link="body"/></joint>
</robot>"""


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    with in_process_app(tmp_path_factory.mktemp("first-hour"), job_workers=1) as c:
        yield c


@pytest.fixture()
def client(app):
    c = Client("http://testserver")
    c._http = app  # (the TestClient is an httpx.Client: the Python client talks to the app in this process)
    return c


def test_floating_base_has_one_answer(app):
    """C11: the upload answered floating_base false at the top and true in its summary."""
    r = app.post("/v1/robots", json={"name": "drone", "urdf": FLOATING_BELOW_ROOT})
    assert r.status_code == 201, r.text
    body = r.json()
    model = dynamics.load_urdf(FLOATING_BELOW_ROOT.encode())
    assert body["floating_base"] is body["summary"]["floating_base"] is bool(model.floating_base) is True
    listed = [x for x in app.get("/v1/robots").json()["robots"] if x["id"] == body["id"]]
    assert listed[0]["floating_base"] is True and app.get(f"/v1/robots/{body['id']}").json()["floating_base"]


def test_bundled_robots_take_the_librarys_names(app):
    """D14: the library says planar_2r, the service said planar-2r (and 404 without a suggestion for the
    other); now the library's name, the dashed one an alias, and an unknown one gets the closest names."""
    ids = [x["id"] for x in app.get("/v1/robots").json()["robots"] if x["bundled"]]
    assert sorted(ids) == sorted(dynamics.robots.names())
    assert {"four_bar", "cassie_like_leg", "stewart_platform"} <= set(ids)
    for name in ("planar_2r", "planar-2r"):
        r = app.post(f"/v1/robots/{name}/mass-matrix", json={"q": [0.1, 0.2]})
        assert r.status_code == 200, r.text
    r = app.post("/v1/robots/planar_2x/mass-matrix", json={"q": [0.1, 0.2]})
    assert r.status_code == 404 and "did you mean 'planar_2r'" in r.json()["detail"], r.text
    r = app.post("/v1/robots/zzzz/mass-matrix", json={"q": [0.1, 0.2]})
    assert r.status_code == 404 and "bundled robots are [" in r.json()["detail"]


def test_client_robot_of_an_empty_name_is_a_clear_error(client):
    """D13: client.robot('') raised a raw JSONDecodeError."""
    with pytest.raises(ValueError, match="robot: expected an id or a name"):
        client.robot("")
    with pytest.raises(ServiceError) as e:
        client.robot("no/such?robot")
    assert e.value.status == 404
    assert client.robot("planar-2r").id == "planar_2r"


def test_a_413_states_a_huge_size_briefly(app):
    """D16: a job whose result would take 1e300 s of samples answered a 413 with a 304-digit number."""
    r = app.post("/v1/jobs", json={"robot": "planar_2r", "kind": "simulate_many",
                                   "options": {"duration": 1e300, "sample_dt": 1e-3},
                                   "inputs": {"q0": [0.1, 0.2], "v0": [0, 0]}})
    assert r.status_code == 413, r.text
    assert not re.search(r"\d{20}", r.json()["detail"]) and re.search(r"\d\.\d\de\+\d+ bytes", r.json()["detail"])


def test_inverse_kinematics_towards_1e308_says_why(app):
    """D16: a target at 1e308 answered 200 with residual null and status "stalled"."""
    r = app.post("/v1/robots/planar_2r/inverse-kinematics",
                 json={"frame": "tip", "target": [1e308, 0, 0], "q0": [0.3, 0.3], "position_only": True})
    assert r.status_code == 422 and r.json()["field"] == "target" and "overflows" in r.json()["detail"], r.text
    r = app.post("/v1/robots/planar_2r/inverse-kinematics",  # unreachable but finite: the library's answer
                 json={"frame": "tip", "target": [5.0, 0, 0], "q0": [0.3, 0.3], "position_only": True})
    assert r.status_code == 200 and r.json()["report"]["status"] == "stalled", r.text


def test_the_client_splits_a_batch_over_the_body_limit(tmp_path):
    """D12: 50,000 Panda states through the client got 413 (8 MiB body limit) though the batch limit is 200,000;
    the client now splits such a batch, and the 413 itself says what to do."""
    model = dynamics.load_urdf(dynamics.robots.path("puma560"))
    q, v, a = np.random.default_rng(0).normal(size=(3, 3000, model.nq))
    with in_process_app(tmp_path, max_body_bytes=64 * 1024) as app:  # 3000 states: 432 KB as .npz
        r = app.post("/v1/robots/puma560/inverse-dynamics", json={"q": q.tolist(), "v": v.tolist(), "a": a.tolist()})
        assert r.status_code == 413 and "client.submit" in r.json()["detail"], r.text
        c = Client("http://testserver")
        c._http = app
        tau = c.robot("puma560").inverse_dynamics(q, v, a)
    assert np.array_equal(tau, dynamics.inverse_dynamics(model, q, v, a))
