"""The service side of issue 5: locked joints on every dynamics and simulate request, the ``scene`` of every
answer, the model summary of robot info and uploads, reduced models cached by (robot, locked set).

Most tests run the app in this process with FastAPI's TestClient (no simulation workers): numbers are compared
exactly with ``dynamics.lock_joints`` + the library called here, and the model cache can be inspected and the
library's ``lock_joints`` counted. The client tests (and simulate, which needs a worker process) use the real
server shared with the other service tests.
"""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from fastapi.testclient import TestClient

import dynamics
from service.app import create_app
from service.client import Client, ServiceError
from service.settings import Settings
from service_fixtures import ROBOTS, shared_server, while_simulation_starts

PUMA_LOCK = {"joint2": 0.3, "joint5": -0.2}

# A floating quadruped-like body: two legs (hip, knee), a battery welded to the base (merged), and massless sensor
# frames with nothing moving below them (an IMU, a camera and its optical frame, a foot frame per leg): pruned.
SENSOR_BOT = """<robot name="sensor_bot">
  <link name="base"><inertial><origin xyz="0 0 0.01"/><mass value="5"/>
    <inertia ixx="0.1" iyy="0.2" izz="0.25" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="battery"><inertial><origin xyz="0 0 -0.02"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="battery_joint" type="fixed"><parent link="base"/><child link="battery"/>
    <origin xyz="-0.1 0 0"/></joint>
  <link name="imu_link"/>
  <joint name="imu_joint" type="fixed"><parent link="base"/><child link="imu_link"/><origin xyz="0.1 0 0.05"/></joint>
  <link name="camera_link"/>
  <joint name="camera_joint" type="fixed"><parent link="base"/><child link="camera_link"/>
    <origin xyz="0.2 0 0.1"/></joint>
  <link name="camera_optical_frame"/>
  <joint name="camera_optical_joint" type="fixed"><parent link="camera_link"/><child link="camera_optical_frame"/>
    <origin rpy="-1.5708 0 -1.5708"/></joint>
  {legs}
</robot>"""
LEG = """
  <link name="{s}_thigh"><inertial><origin xyz="0 0 -0.1"/><mass value="0.8"/>
    <inertia ixx="0.004" iyy="0.004" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="{s}_hip" type="revolute"><parent link="base"/><child link="{s}_thigh"/>
    <origin xyz="0.15 {y} 0"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="20" velocity="10"/></joint>
  <link name="{s}_shin"><inertial><origin xyz="0 0 -0.1"/><mass value="0.3"/>
    <inertia ixx="0.002" iyy="0.002" izz="0.0005" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="{s}_knee" type="revolute"><parent link="{s}_thigh"/><child link="{s}_shin"/>
    <origin xyz="0 0 -0.2"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="0" effort="20" velocity="10"/></joint>
  <link name="{s}_foot"/>
  <joint name="{s}_foot_joint" type="fixed"><parent link="{s}_shin"/><child link="{s}_foot"/>
    <origin xyz="0 0 -0.2"/></joint>"""
SENSOR_BOT = SENSOR_BOT.replace("{legs}", LEG.format(s="left", y=0.1) + LEG.format(s="right", y=-0.1))
PRUNED = {"imu_link", "camera_link", "camera_optical_frame", "left_foot", "right_foot"}
FIXED_JOINTS = {"battery_joint", "imu_joint", "camera_joint", "camera_optical_joint", "left_foot_joint",
                "right_foot_joint"}
BASE_POSE = [0.1, -0.2, 0.5, 0.0, 0.0, float(np.sin(0.2)), float(np.cos(0.2))]  # x y z qx qy qz qw


# -- in-process app -----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def app_client(tmp_path_factory):
    settings = Settings(store_dir=tmp_path_factory.mktemp("scene-store"), robots_dir=ROBOTS, sim_workers=0,
                        compute_threads=1, cache_size=6)
    with TestClient(create_app(settings)) as c:
        yield c


@pytest.fixture(scope="module")
def puma():
    return dynamics.load_urdf(str(ROBOTS / "puma560.urdf"))


@pytest.fixture(scope="module")
def sensor_bot(app_client):
    r = app_client.post("/v1/robots", json={"urdf": SENSOR_BOT, "floating_base": True})
    assert r.status_code == 201, r.text
    return r.json()


def random_q(model, rng, batch=None):
    """Random configurations, free-flyer quaternions normalised; (nq,) or (batch, nq)."""
    q = rng.uniform(-1.0, 1.0, (batch or 1, model.nq))
    for k in model.quaternion_starts:
        q[:, k:k + 4] /= np.linalg.norm(q[:, k:k + 4], axis=1, keepdims=True)
    return q[0] if batch is None else q


def ask(c, rid, op, **payload):
    body = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in payload.items()}
    r = c.post(f"/v1/robots/{rid}/{op}", json=body)
    assert r.status_code == 200, r.text
    out = r.json()
    return np.asarray(next(v for k, v in out.items() if k != "scene")), out["scene"]


def every_endpoint(c, rid, model, rng, batch, locked, gravity=None):
    """Ask every dynamics endpoint with ``locked`` and compare with the library on ``model`` (already reduced)."""
    q = random_q(model, rng, batch)
    v, a = rng.normal(size=(2, *q.shape[:-1], model.nv))
    g = {} if gravity is None else {"gravity": gravity}
    cases = [
        ("inverse-dynamics", dict(q=q, v=v, a=a, **g), dynamics.inverse_dynamics(model, q, v, a, **g)),
        ("forward-dynamics", dict(q=q, v=v, tau=a, **g), dynamics.forward_dynamics(model, q, v, a, **g)),
        ("mass-matrix", dict(q=q), dynamics.mass_matrix(model, q)),
        ("gravity-torques", dict(q=q, **g), dynamics.gravity_torques(model, q, **g)),
        ("bias-forces", dict(q=q, v=v, **g), dynamics.bias_forces(model, q, v, **g)),
    ]
    for op, payload, expected in cases:
        got, scene = ask(c, rid, op, locked=locked, **payload)
        assert np.array_equal(got, expected), op
        assert (scene["nq"], scene["nv"]) == (model.nq, model.nv)


# -- numbers ------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("batch", [None, 5])
def test_locked_puma_matches_lock_joints_and_the_library(app_client, puma, batch):
    reduced = dynamics.lock_joints(puma, PUMA_LOCK)
    assert reduced.nv == 4
    every_endpoint(app_client, "puma560", reduced, np.random.default_rng(1), batch, PUMA_LOCK)
    every_endpoint(app_client, "puma560", reduced, np.random.default_rng(2), batch, PUMA_LOCK,
                   gravity=[0.0, 9.81, -1.0])


def test_locked_floating_base_matches_lock_joints_and_the_library(app_client, sensor_bot):
    model = dynamics.load_urdf(SENSOR_BOT.encode(), floating_base=True)
    assert (sensor_bot["nq"], sensor_bot["nv"]) == (model.nq, model.nv) == (11, 10)
    rng = np.random.default_rng(3)
    for locked in ({"left_knee": 0.4, "right_knee": [-0.3]},  # still floating: q has a quaternion
                   {"root_joint": BASE_POSE, "right_hip": 0.2}):  # base welded to the world
        reduced = dynamics.lock_joints(model, locked)
        every_endpoint(app_client, sensor_bot["id"], reduced, rng, 3, locked)
    assert reduced.nv == 3 and not reduced.floating_base


def test_npz_answer_carries_the_scene(app_client, puma):
    reduced = dynamics.lock_joints(puma, PUMA_LOCK)
    q = random_q(reduced, np.random.default_rng(4), 50)
    buf = io.BytesIO()
    np.savez(buf, q=q, v=np.zeros_like(q), locked=np.array(json.dumps(PUMA_LOCK)))  # objects as JSON in .npz
    r = app_client.post("/v1/robots/puma560/bias-forces", content=buf.getvalue(),
                        headers={"Content-Type": "application/x-npz", "Accept": "application/x-npz"})
    assert r.status_code == 200, r.text
    with np.load(io.BytesIO(r.content), allow_pickle=False) as z:
        assert np.array_equal(z["tau"], dynamics.bias_forces(reduced, q, np.zeros_like(q)))
        scene = json.loads(str(z["scene"]))
    assert scene["locked"] == PUMA_LOCK and scene["nv"] == 4
    assert scene["skipped"] == ["velocity products", "joint accelerations"]


# -- refusals -----------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("locked, field, words", [
    ({"elbow": 0.1}, "locked", ["no movable joint named 'elbow'", "joint1"]),
    ({"joint2": [0.1, 0.2]}, "locked['joint2']", ["expected 1 finite number"]),
    ({"joint2": float("nan")}, "locked['joint2']", ["finite"]),
    ({"joint2": "up"}, "locked['joint2']", ["expected a number"]),
    ({"joint2": True}, "locked['joint2']", ["expected a number"]),
    ({"joint2": [[0.1]]}, "locked['joint2']", ["expected a number"]),
    ([0.1, 0.2], "locked", ["expected an object"]),
    ("joint2", "locked", ["not a JSON object"]),
])
def test_bad_locked_is_a_422_naming_the_joint(app_client, locked, field, words):
    for op, payload in [("inverse-dynamics", {"q": [0.0] * 5, "v": [0.0] * 5, "a": [0.0] * 5}),
                        ("mass-matrix", {"q": [0.0] * 5})]:
        r = app_client.post(f"/v1/robots/puma560/{op}", content=json.dumps({**payload, "locked": locked}),
                            headers={"Content-Type": "application/json"})  # (json.dumps writes NaN)
        assert r.status_code == 422, r.text
        body = r.json()
        assert body["field"] == field and body["detail"].startswith(field + ":"), body
        assert all(w in body["detail"] for w in words), body


def test_bad_floating_lock_and_states_of_the_full_model_are_422(app_client, sensor_bot):
    rid = sensor_bot["id"]
    r = app_client.post(f"/v1/robots/{rid}/gravity-torques", json={"q": [0.0] * 11,
                                                                    "locked": {"root_joint": [0, 0, 1]}})
    assert r.status_code == 422 and r.json()["field"] == "locked['root_joint']"
    assert "expected 7 finite numbers" in r.json()["detail"]
    r = app_client.post(f"/v1/robots/{rid}/gravity-torques", json={"q": [0.0] * 4,
                                                                    "locked": {"root_joint": [0] * 7}})
    assert r.status_code == 422 and r.json()["field"] == "locked['root_joint']"
    assert "quaternion" in r.json()["detail"]
    # with a locked set, states are those of the reduced model: the full model's q is refused, naming q
    r = app_client.post("/v1/robots/puma560/inverse-dynamics",
                        json={"q": [[0.0] * 6] * 2, "v": [[0.0] * 4] * 2, "a": [[0.0] * 4] * 2,
                              "locked": PUMA_LOCK})
    assert r.status_code == 422 and r.json()["field"] == "q" and "(B, 4)" in r.json()["detail"], r.text
    r = app_client.post("/v1/robots/puma560/gravity-torques", json={"q": [0.0] * 6, "gravity": [0, 0]})
    assert r.status_code == 422 and r.json()["field"] == "gravity"


# -- scene and summary --------------------------------------------------------------------------------------------
def test_scene_reports_locked_pruned_and_skipped(app_client, sensor_bot):
    rid = sensor_bot["id"]
    locked = {"left_knee": 0.4}
    q = [0.0, 0.0, 0.3, 0.0, 0.0, 0.0, 1.0, 0.1, 0.2, -0.3]  # 7 + 3 joints left
    zero, one = [0.0] * 9, [1.0] * 9
    cases = [
        ("inverse-dynamics", {"v": one, "a": one}, []),
        ("inverse-dynamics", {"v": zero, "a": one}, ["velocity products"]),
        ("inverse-dynamics", {"v": one, "a": zero}, ["joint accelerations"]),
        ("inverse-dynamics", {"v": zero, "a": zero, "gravity": [0, 0, 0]},
         ["velocity products", "joint accelerations", "gravity"]),
        ("forward-dynamics", {"v": zero, "tau": one}, ["velocity products"]),
        ("forward-dynamics", {"v": one, "tau": one, "gravity": [0, 0, 0]}, ["gravity"]),
        ("gravity-torques", {}, ["velocity products", "joint accelerations"]),
        ("bias-forces", {"v": one}, ["joint accelerations"]),
        ("mass-matrix", {}, []),
    ]
    for op, extra, skipped in cases:
        _, scene = ask(app_client, rid, op, q=q, locked=locked, **extra)
        assert scene == {"locked": locked, "links_pruned": scene["links_pruned"],
                         "fixed_joints_merged": scene["fixed_joints_merged"], "skipped": skipped, "nq": 10,
                         "nv": 9}, (op, extra)
        assert set(scene["links_pruned"]) == PRUNED
        assert set(scene["fixed_joints_merged"]) == FIXED_JOINTS
    _, scene = ask(app_client, "puma560", "gravity-torques", q=[0.0] * 6)
    assert scene["locked"] == {} and scene["links_pruned"] == [] and scene["nv"] == 6
    # the scene's names and values are the model summary's (robot info)
    summary = app_client.get("/v1/robots/puma560").json()["summary"]
    assert scene["fixed_joints_merged"] == summary["fixed_joints_merged"] and len(summary["fixed_joints_merged"]) == 6
    assert scene["links_pruned"] == summary["links_pruned"]


def test_upload_and_info_carry_the_model_summary(app_client, sensor_bot):
    for info in (sensor_bot, app_client.get(f"/v1/robots/{sensor_bot['id']}").json()):
        s = info["summary"]
        assert set(s["links_pruned"]) == PRUNED and "battery_joint" in s["fixed_joints_merged"]
        assert (s["urdf_links"], s["urdf_joints"], s["bodies"]) == (11, 10, 5)
        assert s["floating_base"] is True and s["locked_joints"] == {} and s["warnings"] == []
        assert (s["nq"], s["nv"]) == (11, 10)
    doc = app_client.get("/openapi.json").json()
    schemas = doc["components"]["schemas"]
    assert "locked" in schemas["InverseDynamicsRequest"]["properties"] and "Scene" in schemas
    assert "locked" in schemas["SimulateRequest"]["properties"]


# -- the model cache ----------------------------------------------------------------------------------------------
def test_reduced_models_are_built_once_per_locked_set(app_client, monkeypatch):
    calls = []
    real = dynamics.lock_joints

    def counting(model, values):
        calls.append(dict(values))
        return real(model, values)

    monkeypatch.setattr(dynamics, "lock_joints", counting)
    cache = app_client.app.state.deps.models.cache
    body = {"q": [0.1] * 4, "v": [0.2] * 4, "a": [0.3] * 4}
    # the same set twice, written differently (order, number or 1-list, -0.0): one lock_joints call
    for locked in ({"joint3": 0.7, "joint4": -0.0}, {"joint4": [0.0], "joint3": 0.7}):
        r = app_client.post("/v1/robots/puma560/inverse-dynamics", json={**body, "locked": locked})
        assert r.status_code == 200 and r.json()["scene"]["locked"] == {"joint3": 0.7, "joint4": 0.0}
    assert len(calls) == 1
    assert cache.peek(("puma560", (("joint3", (0.7,)), ("joint4", (0.0,))))) is not None
    hits = cache.hits
    app_client.post("/v1/robots/puma560/gravity-torques", json={"q": [0.1] * 4,
                                                                "locked": {"joint3": 0.7, "joint4": 0}})
    assert len(calls) == 1 and cache.hits > hits  # another endpoint, same reduced model
    # another value is another model; the cache stays bounded (cache_size=6) and least recently used go first
    for k in range(8):
        r = app_client.post("/v1/robots/puma560/gravity-torques", json={"q": [0.1] * 5,
                                                                        "locked": {"joint6": 0.1 * k}})
        assert r.status_code == 200
    assert len(calls) == 9 and len(cache) <= 6
    assert cache.peek(("puma560", (("joint3", (0.7,)), ("joint4", (0.0,))))) is None


# -- through the Python client and the real server (simulate runs in its worker process) ---------------------------
@pytest.fixture(scope="module")
def client(tmp_path_factory):
    server = shared_server(tmp_path_factory.getbasetemp())
    with Client(server.url) as c:
        yield c


def test_client_passes_locked_and_gravity_and_keeps_the_scene(client, puma):
    robot = client.robot("puma560")
    assert robot.last_scene is None
    reduced = dynamics.lock_joints(puma, PUMA_LOCK)
    rng = np.random.default_rng(5)
    g = np.array([0.0, 0.0, 0.0])
    for batch in (None, 1000):  # 1000 x 4 x 3 numbers > the client's threshold: .npz both ways
        q = random_q(reduced, rng, batch)
        v, a = rng.normal(size=(2, *q.shape))
        assert np.array_equal(robot.inverse_dynamics(q, v, a, locked=PUMA_LOCK, gravity=g),
                              dynamics.inverse_dynamics(reduced, q, v, a, gravity=g))
        assert robot.last_scene["skipped"] == ["gravity"] and robot.last_scene["locked"] == PUMA_LOCK
        assert np.array_equal(robot.forward_dynamics(q, v, a, locked=PUMA_LOCK),
                              dynamics.forward_dynamics(reduced, q, v, a))
        assert np.array_equal(robot.mass_matrix(q, locked=PUMA_LOCK), dynamics.mass_matrix(reduced, q))
        assert robot.last_scene["skipped"] == [] and robot.last_scene["nv"] == 4
        assert np.array_equal(robot.gravity_torques(q, locked=PUMA_LOCK), dynamics.gravity_torques(reduced, q))
        assert np.array_equal(robot.bias_forces(q, v, locked=PUMA_LOCK, gravity=g),
                              dynamics.bias_forces(reduced, q, v, gravity=g))
    assert isinstance(robot.gravity_torques(np.zeros(6)), np.ndarray)  # return types unchanged
    assert robot.last_scene["locked"] == {} and robot.last_scene["nv"] == 6
    with pytest.raises(ServiceError) as e:
        robot.gravity_torques(np.zeros(5), locked={"wrist": 0.0})
    assert e.value.status == 422 and e.value.field == "locked" and "'wrist'" in e.value.message


def test_simulate_with_locked_joints(client, puma):
    robot = client.robot("puma560")
    traj = while_simulation_starts(lambda: robot.simulate(np.zeros(4), np.zeros(4), 0.1, locked=PUMA_LOCK,
                                                          gravity=[0.0, 0.0, 0.0], sample_dt=0.05))
    assert traj.q.shape == (3, 4) and traj.tau.shape == (3, 4)
    assert np.array_equal(traj.q, np.zeros((3, 4)))  # no gravity, at rest: stays
    assert robot.last_scene == {"locked": PUMA_LOCK, "links_pruned": [],
                                "fixed_joints_merged": puma.summary()["fixed_joints_merged"],
                                "skipped": ["gravity"], "nq": 4, "nv": 4}
    q0 = np.array([0.1, 0.2, -0.3, 0.4])
    traj = robot.simulate(q0, np.zeros(4), 0.2, locked=PUMA_LOCK, sample_dt=0.1)
    assert robot.last_scene["skipped"] == [] and traj.report["status"] == "ok"
    # the worker ran the library on the same reduced model
    local = dynamics.simulate(dynamics.lock_joints(puma, PUMA_LOCK), q0, np.zeros(4), 0.2, sample_dt=0.1,
                              max_steps=1_000_000)
    assert np.array_equal(traj.q, local.q)
    for locked, field in [({"joint9": 0.0}, "locked"), ({"joint2": [1, 2]}, "locked['joint2']")]:
        with pytest.raises(ServiceError) as e:
            robot.simulate(np.zeros(4), np.zeros(4), 0.1, locked=locked)
        assert e.value.status == 422 and e.value.field == field, e.value.message
