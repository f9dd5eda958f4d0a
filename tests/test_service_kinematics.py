"""The service side of issue 9 (kinematics and task space) and of issue 13 item 8 (Coriolis matrix, energies,
robot info with masses, inertias and frames).

Every number is compared bit for bit with the library called here on the same model (the library itself is
checked against Pinocchio in tests/test_kinematics_pinocchio.py). The in-process app (FastAPI's TestClient, no
simulation workers) covers the endpoints, batches, .npz, ``locked`` and the refusals; the client methods run
against the real server shared with the other service tests.
"""

from __future__ import annotations

import io

import numpy as np
import pytest

import dynamics
from service.client import Client, ServiceError
from service_fixtures import ROBOTS, in_process_app, shared_server

PUMA_LOCK = {"joint2": 0.3, "joint5": -0.2}


@pytest.fixture(scope="module")
def app_client(tmp_path_factory):
    with in_process_app(tmp_path_factory.mktemp("kin-store"), max_json_answer_bytes=21 * 100_000) as c:
        yield c


@pytest.fixture(scope="module")
def puma():
    return dynamics.load_urdf(str(ROBOTS / "puma560.urdf"))


@pytest.fixture(scope="module")
def floating_puma(app_client):
    """puma560 on a free base of 20 kg: quaternions in q, frames below a root joint."""
    text = (ROBOTS / "puma560.urdf").read_text().replace('<link name="base_link"/>', """<link name="base_link">
      <inertial><mass value="20"/><inertia ixx="0.5" iyy="0.5" izz="0.3" ixy="0" ixz="0" iyz="0"/></inertial>
      </link>""", 1)
    r = app_client.post("/v1/robots", json={"urdf": text, "floating_base": True})
    assert r.status_code == 201, r.text
    return r.json()["id"], dynamics.load_urdf(text.encode(), floating_base=True)


def random_state(model, rng, batch=None):
    q = rng.uniform(-1.0, 1.0, (batch or 1, model.nq))
    for k in model.quaternion_starts:
        q[:, k:k + 4] /= np.linalg.norm(q[:, k:k + 4], axis=1, keepdims=True)
    v = rng.normal(size=(batch or 1, model.nv))
    return (q[0], v[0]) if batch is None else (q, v)


def post(c, rid, op, **payload):
    body = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in payload.items()}
    r = c.post(f"/v1/robots/{rid}/{op}", json=body)
    assert r.status_code == 200, r.text
    return r.json()


def every_endpoint(c, rid, model, q, v, locked=None):
    """Each kinematics, Coriolis and energy endpoint against the library on ``model`` (reduced when locked)."""
    lk = {} if locked is None else {"locked": locked}
    tip = model.frame_names[-1]
    some = [model.frame_names[k] for k in (-1, 0, len(model.frame_names) // 2)]
    ans = post(c, rid, "kinematics", q=q, **lk)
    assert ans["frames"] == list(model.frame_names)
    assert np.array_equal(ans["placements"], dynamics.forward_kinematics(model, q))
    ans = post(c, rid, "kinematics", q=q, frames=some, **lk)
    assert ans["frames"] == some
    assert np.array_equal(ans["placements"], dynamics.forward_kinematics(model, q)[..., [model.frame_index(n)
                                                                                        for n in some], :, :])
    for reference in ("local_world_aligned", "local", "world"):
        for point in (None, [0.01, -0.02, 0.05]):
            extra = {} if point is None else {"point": point}
            got = post(c, rid, "jacobian", q=q, frame=tip, reference=reference, **extra, **lk)["jacobian"]
            assert np.array_equal(got, dynamics.frame_jacobian(model, q, tip, reference=reference, point=point))
    ans = post(c, rid, "center-of-mass", q=q, v=v, **lk)
    assert np.array_equal(ans["center_of_mass"], dynamics.center_of_mass(model, q))
    assert np.array_equal(ans["com_jacobian"], dynamics.com_jacobian(model, q))
    assert np.array_equal(ans["center_of_mass_velocity"], dynamics.center_of_mass_velocity(model, q, v))
    assert ans["total_mass"] == model.total_mass
    assert "center_of_mass_velocity" not in post(c, rid, "center-of-mass", q=q, **lk)
    assert np.array_equal(post(c, rid, "inverse-mass-matrix", q=q, **lk)["inverse_mass_matrix"],
                          dynamics.inverse_mass_matrix(model, q))
    d = {} if model.nv >= 6 else {"damping": 1e-6}  # 4 joints cannot move the flange's position freely
    got = post(c, rid, "operational-space-inertia", q=q, frame=tip, rows=[0, 1, 2], **d, **lk)
    assert np.array_equal(got["operational_space_inertia"],
                          dynamics.operational_space_inertia(model, q, tip, rows=[0, 1, 2], **d))
    got = post(c, rid, "operational-space-inertia", q=q, frame=tip, reference="local", damping=1e-3, **lk)
    assert np.array_equal(got["operational_space_inertia"],
                          dynamics.operational_space_inertia(model, q, tip, reference="local", damping=1e-3))
    assert np.array_equal(post(c, rid, "coriolis-matrix", q=q, v=v, **lk)["coriolis_matrix"],
                          dynamics.coriolis_matrix(model, q, v))
    assert np.array_equal(post(c, rid, "kinetic-energy", q=q, v=v, **lk)["kinetic_energy"],
                          dynamics.kinetic_energy(model, q, v))
    ans = post(c, rid, "potential-energy", q=q, gravity=[0.0, 1.0, -3.0], **lk)
    assert np.array_equal(ans["potential_energy"], dynamics.potential_energy(model, q, gravity=[0.0, 1.0, -3.0]))
    assert (ans["scene"]["nq"], ans["scene"]["nv"]) == (model.nq, model.nv)


@pytest.mark.parametrize("batch", [None, 4])
def test_every_endpoint_matches_the_library(app_client, puma, floating_puma, batch):
    rng = np.random.default_rng(3)
    every_endpoint(app_client, "puma560", puma, *random_state(puma, rng, batch))
    rid, model = floating_puma
    every_endpoint(app_client, rid, model, *random_state(model, rng, batch))


def test_locked_joints(app_client, puma):
    reduced = dynamics.lock_joints(puma, PUMA_LOCK)
    every_endpoint(app_client, "puma560", reduced, *random_state(reduced, np.random.default_rng(4), 3),
                   locked=PUMA_LOCK)


def test_inverse_kinematics_converges_and_reports_the_unreachable(app_client, puma):
    rng = np.random.default_rng(5)
    q_goal, _ = random_state(puma, rng, 3)
    tip = puma.frame_names[-1]
    target = dynamics.forward_kinematics(puma, q_goal)[:, puma.frame_index(tip)]
    q0 = q_goal + 0.1
    ans = post(app_client, "puma560", "inverse-kinematics", frame=tip, target=target, q0=q0)
    q, report = dynamics.inverse_kinematics(puma, tip, target, q0)
    assert np.array_equal(ans["q"], q)
    assert ans["report"]["converged"] == [True] * 3 and ans["report"]["status"] == ["converged"] * 3
    assert ans["report"]["residual"] == report["residual"].tolist()
    far = [10.0, 0.0, 0.0]
    ans = post(app_client, "puma560", "inverse-kinematics", frame=tip, target=far, q0=q0[0], position_only=True,
               max_iter=50)
    q, report = dynamics.inverse_kinematics(puma, tip, far, q0[0], position_only=True, max_iter=50)
    assert np.array_equal(ans["q"], q) and ans["report"] == report
    assert ans["report"]["converged"] is False and ans["report"]["position_error"] > 8.0


def test_npz_both_ways(app_client, puma):
    rng = np.random.default_rng(6)
    q, v = random_state(puma, rng, 300)
    for op, payload, key, expected in [
            ("kinematics", {"q": q, "frames": np.array(["link6", "link2"])}, "placements",
             dynamics.forward_kinematics(puma, q)[:, [puma.frame_index("link6"), puma.frame_index("link2")]]),
            ("jacobian", {"q": q, "frame": np.array("link6"), "reference": np.array("world")}, "jacobian",
             dynamics.frame_jacobian(puma, q, "link6", reference="world")),
            ("operational-space-inertia", {"q": q, "frame": np.array("link6"), "rows": np.array([0, 1, 2])},
             "operational_space_inertia", dynamics.operational_space_inertia(puma, q, "link6", rows=[0, 1, 2])),
            ("coriolis-matrix", {"q": q, "v": v}, "coriolis_matrix", dynamics.coriolis_matrix(puma, q, v)),
            ("kinetic-energy", {"q": q, "v": v}, "kinetic_energy", dynamics.kinetic_energy(puma, q, v))]:
        buf = io.BytesIO()
        np.savez(buf, **payload)
        r = app_client.post(f"/v1/robots/puma560/{op}", content=buf.getvalue(),
                            headers={"Content-Type": "application/x-npz", "Accept": "application/x-npz"})
        assert r.status_code == 200, r.text
        with np.load(io.BytesIO(r.content), allow_pickle=False) as npz:
            assert np.array_equal(npz[key], expected), op
            assert "scene" in npz.files


@pytest.mark.parametrize("op, payload, field, words", [
    ("jacobian", {"frame": "link_6"}, "frame", ["no frame named 'link_6'", "link6"]),
    ("kinematics", {"frames": ["link1", "lnk2"]}, "frame", ["no frame named 'lnk2'", "link2"]),
    ("jacobian", {"frame": "link6", "reference": "global"}, "reference", ["local_world_aligned"]),
    ("jacobian", {"frame": "link6", "point": [1.0, 2.0]}, "point", ["(3,)"]),
    ("jacobian", {"frame": 99}, "frame", ["out of range"]),
    ("operational-space-inertia", {"frame": "link6", "rows": [0, 7]}, "rows", ["[0, 6)"]),
    ("operational-space-inertia", {"frame": "base_link"}, None, ["singular", "condition number", "damping"]),
    ("inverse-kinematics", {"frame": "link6", "target": [1.0, 2.0], "q0": [0.0] * 6}, "target", ["(4, 4)"]),
    ("inverse-kinematics", {"frame": "link6", "target": [0.1, 0.2, 0.3], "q0": [0.0] * 6, "max_iter": 10 ** 6},
     "max_iter", ["10000"]),
    ("kinematics", {"q": [0.0] * 5}, "q", ["(6,)"]),
    ("center-of-mass", {"v": [0.0] * 2}, "v", ["(6,)"]),
    ("kinematics", {"frame": "link6"}, "frame", ["unknown field", "frames"]),
])
def test_bad_input_is_a_422_naming_the_field(app_client, op, payload, field, words):
    body = {"q": [0.1] * 6, **payload} if op != "inverse-kinematics" else payload
    r = app_client.post(f"/v1/robots/puma560/{op}", json=body)
    assert r.status_code == 422, r.text
    assert r.json()["field"] == field
    for w in words:
        assert w in r.json()["detail"]


@pytest.mark.parametrize("payload", [{"q": [[0.0] * 6] * 400}, {"frames": ["link6"] * 7000}])
def test_answers_over_the_limit_are_refused_before_any_work(app_client, payload):
    """Every frame of 400 states, or one frame named 7000 times (one state): over 100,000 numbers as JSON."""
    r = app_client.post("/v1/robots/puma560/kinematics", json={"q": [0.1] * 6, **payload})
    assert r.status_code == 413, r.text
    assert r.json()["field"] == "answer" and "DYNAMICS_MAX_JSON_ANSWER_BYTES" in r.json()["detail"]


def test_robot_info_lists_frames_masses_and_inertias(app_client, puma):
    info = app_client.get("/v1/robots/puma560").json()
    assert [f["name"] for f in info["frames"]] == list(puma.frame_names)
    for f in info["frames"]:
        body, T = puma.frames[f["name"]]
        assert f["body"] == (puma.body_names[body] if body >= 0 else None)
        assert np.array_equal(f["placement"], T)
    assert info["total_mass"] == puma.total_mass
    assert np.array_equal(info["masses"], puma.masses)
    assert np.array_equal(info["coms"], puma.coms)
    assert np.array_equal(info["inertias"], puma.inertias)
    assert len(info["masses"]) == len(info["bodies"])


# -- the client, against the real server --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def client(tmp_path_factory):
    with Client(shared_server(tmp_path_factory.getbasetemp()).url) as c:
        yield c


def test_client_methods_have_the_library_names(client, puma):
    robot = client.robot("puma560")
    assert robot.frame_names == puma.frame_names
    rng = np.random.default_rng(7)
    for batch in (None, 3, 400):  # 400 states travel as .npz
        q, v = random_state(puma, rng, batch)
        assert np.array_equal(robot.forward_kinematics(q), dynamics.forward_kinematics(puma, q))
        assert np.array_equal(robot.frame_placement(q, "link4"), dynamics.frame_placement(puma, q, "link4"))
        assert np.array_equal(robot.frame_jacobian(q, "link6", reference="local", point=[0, 0, 0.1]),
                              dynamics.frame_jacobian(puma, q, "link6", reference="local", point=[0, 0, 0.1]))
        assert np.array_equal(robot.center_of_mass(q), dynamics.center_of_mass(puma, q))
        assert np.array_equal(robot.center_of_mass_velocity(q, v), dynamics.center_of_mass_velocity(puma, q, v))
        assert np.array_equal(robot.com_jacobian(q), dynamics.com_jacobian(puma, q))
        assert np.array_equal(robot.inverse_mass_matrix(q), dynamics.inverse_mass_matrix(puma, q))
        assert np.array_equal(robot.operational_space_inertia(q, "link6", rows=slice(0, 3)),
                              dynamics.operational_space_inertia(puma, q, "link6", rows=slice(0, 3)))
        assert np.array_equal(robot.coriolis_matrix(q, v), dynamics.coriolis_matrix(puma, q, v))
        assert np.array_equal(robot.kinetic_energy(q, v), dynamics.kinetic_energy(puma, q, v))
        assert np.array_equal(robot.potential_energy(q), dynamics.potential_energy(puma, q))
    target = dynamics.frame_placement(puma, q[:2], "link6")
    got_q, got_report = robot.inverse_kinematics("link6", target, q[:2] + 0.05)
    want_q, want_report = dynamics.inverse_kinematics(puma, "link6", target, q[:2] + 0.05)
    assert np.array_equal(got_q, want_q)
    assert got_report.keys() == want_report.keys()
    for k in want_report:
        assert np.array_equal(got_report[k], want_report[k]), k
    with pytest.raises(ServiceError) as e:
        robot.frame_jacobian(q[0], "link_6")
    assert e.value.status == 422 and e.value.field == "frame" and "link6" in e.value.message
