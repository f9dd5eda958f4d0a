"""The service side of issue 10: constraints on upload (the URDF <loop> element, a JSON list, the mimic option),
listed in robot info, and the closed-loop endpoints (constraint-residual, assemble, constrained forward and inverse
dynamics) with batches, .npz, ``locked`` and ``scene``.

Every number is compared bit for bit with the library called here on the same model (the library itself is
checked against the lectures' closed form and Pinocchio in tests/test_constraints_*.py), through the in-process
app; the client methods run against the same app (its httpx transport is the TestClient).
"""

from __future__ import annotations

import io
import time

import numpy as np
import pytest
from lxml import etree

import dynamics
from service.client import Client, ServiceError
from service_fixtures import ROBOTS, in_process_app, shared_server, while_simulation_starts

LEG_ACTUATED = ["hip_roll", "hip_yaw", "hip_pitch", "knee", "toe", "rod_pitch"]


@pytest.fixture(scope="module")
def app_client(tmp_path_factory):
    with in_process_app(tmp_path_factory.mktemp("constraints-store")) as c:
        yield c


@pytest.fixture(scope="module")
def four_bar():
    fb = dynamics.load_urdf(str(ROBOTS / "four_bar.urdf"))
    Q = np.array([dynamics.assemble(fb, [c, 0.5, 1.5], fixed=["theta1"]) for c in (0.1, 0.7, 1.3)])
    V = dynamics.project_velocity(fb, Q, np.tile([1.0, 0.0, 0.0], (3, 1)))
    return fb, Q, V


@pytest.fixture(scope="module")
def leg():
    leg = dynamics.load_urdf(str(ROBOTS / "cassie_like_leg.urdf"))
    rng = np.random.default_rng(0)
    Q = np.array([dynamics.assemble(leg, leg.neutral() + rng.uniform(-0.1, 0.1, leg.nq), fixed=LEG_ACTUATED[:5])
                  for _ in range(3)])
    V = dynamics.project_velocity(leg, Q, rng.normal(size=(3, leg.nv)))
    return leg, Q, V, rng.normal(size=(3, leg.nv))


def bare(path):
    """The URDF at ``path`` without its <loop> elements (the tree alone)."""
    root = etree.fromstring((ROBOTS / path).read_bytes())
    for el in root.findall("loop"):
        root.remove(el)
    return etree.tostring(root).decode()


def post(c, rid, op, status=200, **payload):
    body = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in payload.items()}
    r = c.post(f"/v1/robots/{rid}/{op}", json=body)
    assert r.status_code == status, r.text
    return r.json()


def spec(c):
    """A library declaration -> its JSON form on upload."""
    return {"type": {"PointConstraint": "point", "RevoluteConstraint": "revolute", "WeldConstraint": "weld",
                     "JointCoupling": "coupling"}[type(c).__name__],
            **{k: (list(v) if isinstance(v, tuple) else v) for k, v in vars(c).items() if v is not None}}


def test_bundled_loops_are_listed_and_every_endpoint_matches_the_library(app_client, four_bar):
    fb, Q, V = four_bar
    info = app_client.get("/v1/robots/four-bar").json()
    assert info["constraints"]["items"] == [{**spec(fb.constraints[0]), "rows": 5}]
    assert (info["constraints"]["rows"], info["constraints"]["rank"], info["constraints"]["mobility"]) == (5, 2, 1)
    tau = np.array([0.2, 0.0, 0.0])
    for q, v in ((Q[0], V[0]), (Q, V)):  # one state and a batch
        ans = post(app_client, "four-bar", "constraint-residual", q=q)
        assert np.array_equal(ans["residual"], dynamics.constraint_residual(fb, q))
        assert ans["scene"]["nv"] == 3
        ans = post(app_client, "four-bar", "constrained-forward-dynamics", q=q, v=v, tau=tau, baumgarte=[5.0, 8.0])
        a, lam = dynamics.constrained_forward_dynamics(fb, q, v, tau, baumgarte=(5.0, 8.0))
        assert np.array_equal(ans["a"], a) and np.array_equal(ans["lambda"], lam)
        a, _ = dynamics.constrained_forward_dynamics(fb, q, v, tau)
        ans = post(app_client, "four-bar", "constrained-inverse-dynamics", q=q, v=v, a=a, actuated=["theta1"])
        assert np.array_equal(ans["tau"], dynamics.constrained_inverse_dynamics(fb, q, v, a, actuated=["theta1"]))
        assert np.allclose(ans["tau"], tau, atol=1e-9)  # the crank's torque comes back
    guesses = np.array([[0.3, 0.5, 1.5], [0.9, 0.4, 1.6]])
    for fixed in (["theta1"], {"theta1": 0.5}):
        ans = post(app_client, "four-bar", "assemble", q_guess=guesses, fixed=fixed)
        assert np.array_equal(ans["q"], dynamics.assemble(fb, guesses, fixed=fixed))
    # forward-dynamics on a constrained robot honours the loop (dynamics.forward_dynamics does)
    ans = post(app_client, "four-bar", "forward-dynamics", q=Q, v=V, tau=np.tile(tau, (3, 1)))
    assert np.array_equal(ans["a"], dynamics.constrained_forward_dynamics(fb, Q, V, np.tile(tau, (3, 1)))[0])


def test_npz_locked_and_a_floating_leg(app_client, leg):
    model, Q, V, T = leg
    buf = io.BytesIO()
    np.savez(buf, q=Q, v=V, tau=T)
    r = app_client.post("/v1/robots/cassie-like-leg/constrained-forward-dynamics", content=buf.getvalue(),
                        headers={"Content-Type": "application/x-npz", "Accept": "application/x-npz"})
    assert r.status_code == 200, r.text
    ans = np.load(io.BytesIO(r.content), allow_pickle=False)
    a, lam = dynamics.constrained_forward_dynamics(model, Q, V, T)
    assert np.array_equal(ans["a"], a) and np.array_equal(ans["lambda"], lam)
    locked = {"hip_roll": 0.05, "hip_yaw": -0.02}
    reduced = dynamics.lock_joints(model, locked)
    keep = [model.v_index[model.joint_index(n)] for n in reduced.joint_names]
    q, v, tau = Q[:, keep], V[:, keep], T[:, keep]
    ans = post(app_client, "cassie-like-leg", "constrained-forward-dynamics", q=q, v=v, tau=tau, locked=locked)
    a, lam = dynamics.constrained_forward_dynamics(reduced, q, v, tau)
    assert np.array_equal(ans["a"], a) and np.array_equal(ans["lambda"], lam)
    assert ans["scene"]["locked"] == locked and ans["scene"]["nv"] == reduced.nv
    a, _ = dynamics.constrained_forward_dynamics(model, Q, V, T)
    ans = post(app_client, "cassie-like-leg", "constrained-inverse-dynamics", q=Q, v=V, a=a, actuated=LEG_ACTUATED)
    assert np.array_equal(ans["tau"], dynamics.constrained_inverse_dynamics(model, Q, V, a, actuated=LEG_ACTUATED))


def test_a_json_constraint_on_upload_is_the_loop_element(app_client, four_bar):
    fb, Q, V = four_bar
    r = app_client.post("/v1/robots", json={"urdf": bare("four_bar.urdf"), "constraints": [spec(fb.constraints[0])]})
    assert r.status_code == 201, r.text
    rid = r.json()["id"]
    assert r.json()["constraints"]["items"] == app_client.get("/v1/robots/four-bar").json()["constraints"]["items"]
    tau = np.tile([0.2, 0.0, 0.0], (3, 1))
    ans = post(app_client, rid, "constrained-forward-dynamics", q=Q, v=V, tau=tau)
    a, lam = dynamics.constrained_forward_dynamics(fb, Q, V, tau)
    assert np.array_equal(ans["a"], a) and np.array_equal(ans["lambda"], lam)
    # the same URDF without the constraint is another robot, whose forward dynamics ignore the loop
    plain = app_client.post("/v1/robots", json={"urdf": bare("four_bar.urdf")}).json()
    assert plain["id"] != rid and plain.get("constraints") is None
    # the <loop> element through an XML upload
    r = app_client.post("/v1/robots", content=(ROBOTS / "four_bar.urdf").read_bytes(),
                        headers={"Content-Type": "application/xml"})
    assert r.status_code == 201 and r.json()["constraints"]["rows"] == 5


def test_joint_frames_welds_and_couplings_on_upload(app_client):
    urdf = (ROBOTS / "planar_2r.urdf").read_text()
    base = dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf"))
    coupling = dynamics.JointCoupling("joint2", "joint1", 0.5, 0.1)
    r = app_client.post("/v1/robots", json={"urdf": urdf, "constraints": [spec(coupling)]})
    assert r.status_code == 201, r.text
    ref = dynamics.with_constraints(base, [coupling])
    q, v, tau = np.array([0.3, 0.25]), np.array([0.4, 0.2]), np.array([1.0, -0.5])
    ans = post(app_client, r.json()["id"], "constrained-forward-dynamics", q=q, v=v, tau=tau)
    a, lam = dynamics.constrained_forward_dynamics(ref, q, v, tau)
    assert np.array_equal(ans["a"], a) and np.array_equal(ans["lambda"], lam)
    # a hinge anchored at a joint frame (joint2's frame is on link2's body): the same mechanism up to rounding
    fb = dynamics.load_urdf(str(ROBOTS / "four_bar.urdf"))
    c = fb.constraints[0]
    frame_a = "theta2" if "theta2" in fb.frame_names else c.frame_a
    body, T = fb.frames[frame_a]
    _, Tl = fb.frames[c.frame_a]
    point_a = np.linalg.solve(T, np.linalg.solve(np.linalg.inv(Tl), np.r_[c.point_a, 1.0]))[:3]
    hinge = dynamics.RevoluteConstraint(frame_a, c.frame_b, c.axis, point_a, c.point_b)
    r = app_client.post("/v1/robots", json={"urdf": bare("four_bar.urdf"), "constraints": [spec(hinge)]})
    assert r.status_code == 201, r.text
    Q = np.array([dynamics.assemble(fb, [0.4, 0.5, 1.5], fixed=["theta1"])])
    ans = post(app_client, r.json()["id"], "constraint-residual", q=Q)
    assert np.abs(ans["residual"]).max() < 1e-12
    # mimic="independent" drops a coupling written as <mimic>
    mimic_urdf = urdf.replace('<joint name="joint2" type="revolute">',
                              '<joint name="joint2" type="revolute"><mimic joint="joint1" multiplier="2"/>')
    r = app_client.post("/v1/robots", json={"urdf": mimic_urdf})
    assert r.json()["constraints"]["items"][0]["multiplier"] == 2.0
    r = app_client.post("/v1/robots", json={"urdf": mimic_urdf, "mimic": "independent"})
    assert r.status_code == 201 and r.json()["constraints"] is None


@pytest.mark.parametrize("constraint, message", [
    ({"type": "point", "frame_a": "lnk2", "frame_b": "link3"}, "closest"),
    ({"type": "coupling", "follower": "theta2", "leader": "no_such_joint"}, "no_such_joint"),
    ({"type": "revolute", "frame_a": "link2", "frame_b": "link3", "axis": [0, 0, 0]}, "axis"),
    ({"type": "point", "frame_a": "link2", "frame_b": "link3", "point_b": [30.0, 0.0, 0.0]}, "cannot close"),
    ([{"type": "weld", "frame_a": "plane", "frame_b": f"link{k}"} for k in (1, 2, 3)], "over-constrained"),
    ({"type": "hinge", "frame_a": "link2", "frame_b": "link3"}, "type"),
])
def test_bad_constraints_on_upload_are_422_naming_the_problem(app_client, constraint, message):
    constraints = constraint if isinstance(constraint, list) else [constraint]
    r = app_client.post("/v1/robots", json={"urdf": bare("four_bar.urdf"), "constraints": constraints})
    assert r.status_code == 422, r.text
    assert message in r.json()["detail"] and "constraints" in r.json()["field"]


def test_bad_requests_are_422_naming_the_problem(app_client, four_bar):
    fb, Q, V = four_bar
    ans = post(app_client, "four-bar", "assemble", 422, q_guess=[0.0, 0.0, 0.0], fixed={"theta1": 0.0, "theta2": 0.0})
    assert "cannot close" in ans["detail"]
    ans = post(app_client, "four-bar", "constrained-inverse-dynamics", 422, q=Q[0], v=V[0], a=[0.0, 0.0, 0.0],
               actuated=["theta9"])
    assert "theta9" in ans["detail"]
    ans = post(app_client, "four-bar", "constrained-inverse-dynamics", 422, q=Q[0], v=V[0], a=[1.0, 0.0, 0.0],
               actuated=["theta1"])
    assert "violates the constraints" in ans["detail"]
    ans = post(app_client, "four-bar", "constrained-forward-dynamics", 422, q=Q[0], v=V[0], tau=[0.0, 0.0],
               baumgarte=[1.0, 1.0])
    assert "tau" in ans["field"]
    ans = post(app_client, "four-bar", "constrained-forward-dynamics", 422, q=Q[0], v=V[0], tau=[0.0] * 3,
               baumgarte=[-1.0, 1.0])
    assert "baumgarte" in ans["detail"]


def test_client_methods_have_the_library_names(app_client, four_bar):
    fb, Q, V = four_bar
    client = Client("http://testserver")
    client._http.close()
    client._http = app_client  # the in-process app as the transport (not closed here: the module shares it)
    robot = client.robot("four-bar")
    assert np.array_equal(robot.constraint_residual(Q), dynamics.constraint_residual(fb, Q))
    assert np.array_equal(robot.assemble([0.3, 0.5, 1.5], fixed=["theta1"]),
                          dynamics.assemble(fb, [0.3, 0.5, 1.5], fixed=["theta1"]))
    tau = np.tile([0.2, 0.0, 0.0], (3, 1))
    a, lam = robot.constrained_forward_dynamics(Q, V, tau, baumgarte=(2.0, 3.0))
    a_ref, lam_ref = dynamics.constrained_forward_dynamics(fb, Q, V, tau, baumgarte=(2.0, 3.0))
    assert np.array_equal(a, a_ref) and np.array_equal(lam, lam_ref)
    a, _ = dynamics.constrained_forward_dynamics(fb, Q, V, tau)
    assert np.array_equal(robot.constrained_inverse_dynamics(Q, V, a, actuated=["theta1"]),
                          dynamics.constrained_inverse_dynamics(fb, Q, V, a, actuated=["theta1"]))
    uploaded = client.upload(bare("four_bar.urdf"), constraints=[fb.constraints[0]])
    assert uploaded.info["constraints"]["rows"] == 5
    with pytest.raises(ServiceError) as e:
        client.upload(bare("four_bar.urdf"), constraints=[{"type": "point", "frame_a": "x", "frame_b": "link3"}])
    assert e.value.status == 422


def test_assemble_runs_within_the_time_budget(app_client):
    guesses = np.tile([0.3, 0.5, 1.5], (2000, 1))
    r = app_client.post("/v1/robots/four-bar/assemble", json={"q_guess": guesses.tolist(), "fixed": ["theta1"]},
                        headers={"X-Time-Budget": "0.05"})
    assert r.status_code == 504, r.text


@pytest.fixture(scope="module")
def sim_client(tmp_path_factory):
    """simulate needs a worker process: the session's shared server."""
    with Client(shared_server(tmp_path_factory.getbasetemp()).url) as c:
        yield c


def test_simulate_returns_the_multipliers_per_sample(sim_client, four_bar):
    fb, Q, V = four_bar
    kw = dict(duration=0.5, sample_dt=0.05, baumgarte=[5.0, 8.0], project=True, error_estimate="none")
    state = {"q0": Q[0].tolist(), "v0": V[0].tolist()}
    ans = while_simulation_starts(lambda: sim_client.call("/v1/robots/four-bar/simulate",
                                                          {**state, **kw, "outputs": ["q", "v", "lambda"]}))
    tr = dynamics.simulate(fb, Q[0], V[0], outputs=("q", "v", "lambda"), **kw)
    lam = np.array(ans["lambda"])
    assert lam.shape == tr.lam.shape == (len(tr.t), 5)
    np.testing.assert_allclose(lam, tr.lam, rtol=0, atol=1e-12 * np.abs(tr.lam).max())
    np.testing.assert_allclose(ans["q"], tr.q, rtol=0, atol=1e-12)
    assert np.array(ans["tau"]).size == 0  # not asked for
    drift = ans["report"]["constraint_drift"]
    assert drift == tr.report["constraint_drift"] and drift["baumgarte"] == [5.0, 8.0] and drift["project"] is True
    # the multipliers are the constrained forward dynamics' at each sample (no torque: tau = 0)
    _, ref = dynamics.constrained_forward_dynamics(fb, tr.q, tr.v, np.zeros_like(tr.v), baumgarte=(5.0, 8.0))
    np.testing.assert_allclose(lam, ref, rtol=0, atol=1e-9 * np.abs(ref).max())
    # without "lambda" there is no lambda member; on a robot without constraints it is an empty (K, 0)
    ans = while_simulation_starts(lambda: sim_client.call("/v1/robots/four-bar/simulate", {**state, **kw}))
    assert "lambda" not in ans and len(ans["tau"]) == len(tr.t)
    ans = while_simulation_starts(lambda: sim_client.call(
        "/v1/robots/planar-2r/simulate", {"q0": [0.1, 0.2], "v0": [0.0, 0.0], "duration": 0.1,
                                          "outputs": ["lambda"], "error_estimate": "none"}))
    assert np.array(ans["lambda"]).size == 0 and np.array(ans["q"]).size == 0
    with pytest.raises(ServiceError) as e:
        sim_client.call("/v1/robots/four-bar/simulate", {**state, "duration": 0.1, "outputs": ["qdd"]})
    assert e.value.status == 422 and "outputs" in str(e.value)


def test_client_simulate_returns_lam(sim_client, four_bar):
    fb, Q, V = four_bar
    robot = sim_client.robot("four-bar")
    kw = dict(sample_dt=0.1, outputs=("q", "v", "lambda"), baumgarte=(0.0, 0.0))
    tr = while_simulation_starts(lambda: robot.simulate(Q[1], V[1], 0.3, **kw))
    ref = dynamics.simulate(fb, Q[1], V[1], 0.3, **kw)
    np.testing.assert_allclose(tr.lam, ref.lam, rtol=0, atol=1e-12 * np.abs(ref.lam).max())
    assert tr.report["constraint_drift"]["baumgarte"] == [0.0, 0.0]
    assert while_simulation_starts(lambda: robot.simulate(Q[1], V[1], 0.1)).lam is None
