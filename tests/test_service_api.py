"""Issue 13 items 8 and 9 on the service side: dop853, the library's torque objects in the client, nested unknown
fields named with their own siblings, and the API documents (examples, typed answers, offline /docs).

Simulations run in the real server shared with the other service tests (a worker process runs the library);
their trajectories are compared bit for bit with the library run here on the same model and torque object.
"""

from __future__ import annotations

import httpx
import numpy as np
import pytest

import dynamics
from dynamics import torques
from service import schemas
from service.client import Client, ServiceError, torque_spec
from service.errors import InvalidInput
from service_fixtures import ROBOTS, in_process_app, shared_server, while_simulation_starts


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    return shared_server(tmp_path_factory.getbasetemp())


@pytest.fixture(scope="module")
def client(server):
    with Client(server.url) as c:
        yield c


@pytest.fixture(scope="module")
def planar():
    return dynamics.load_urdf(str(ROBOTS / "planar_2r.urdf"))


# -- item 8: simulate ---------------------------------------------------------------------------------------------
def test_dop853_and_the_librarys_torque_objects(client, planar):
    robot = client.robot("planar-2r")
    q0, v0 = np.array([0.3, -0.2]), np.array([0.0, 0.5])
    t = np.linspace(0.0, 0.4, 9)
    ref_q = np.stack([0.3 + 0.2 * np.sin(t), -0.2 + 0.1 * t], axis=1)
    ref_v = np.stack([0.2 * np.cos(t), 0.1 + 0 * t], axis=1)
    ref_a = np.stack([-0.2 * np.sin(t), 0 * t], axis=1)
    cases = [
        (torques.PD([0.5, 0.5], np.array([50.0, 20.0]), 4.0, tau_ff=[0.1, 0.0]), {}),
        (torques.Table([0.0, 0.2, 0.4], [[0, 0], [2, 4], [0, 1]], hold="zoh"), {}),
        (torques.ComputedTorque(t, ref_q, ref_v, ref_a, 100.0, 20.0), {}),
        (torques.PD([0.5, 0.5], 50.0, 4.0), {"integrator": "dop853", "rtol": 1e-10, "atol": 1e-12}),
        (np.array([1.0, -2.0]), {"integrator": "dop853"}),
    ]
    for torque, options in cases:
        traj = while_simulation_starts(lambda: robot.simulate(q0, v0, 0.4, torque=torque, sample_dt=0.05, **options))
        local = dynamics.simulate(planar, q0, v0, 0.4, torque=torque, sample_dt=0.05, max_steps=1_000_000,
                                  **options)
        for name in ("t", "q", "v", "tau"):
            assert np.array_equal(getattr(traj, name), getattr(local, name)), (type(torque).__name__, name)
        assert traj.report["integrator"] == local.report["integrator"]
    assert traj.report["integrator"] == "dop853"


def test_torque_spec_of_objects_and_dicts():
    assert torque_spec(None) is None
    assert torque_spec({"type": "pd", "q_target": np.zeros(2), "kp": 1, "kd": 2}) == {
        "type": "pd", "q_target": [0.0, 0.0], "kp": 1, "kd": 2}
    assert torque_spec(torques.PD(np.zeros(2), 1.0, [2.0, 3.0])) == {
        "type": "pd", "q_target": [0.0, 0.0], "kp": 1.0, "kd": [2.0, 3.0]}
    assert torque_spec(torques.Table([0, 1], [[1], [2]])) == {"type": "table", "t": [0, 1], "tau": [[1], [2]],
                                                             "hold": "linear"}
    assert torque_spec([1.0, 2.0]) == {"type": "constant", "tau": [1.0, 2.0]}
    with pytest.raises(TypeError, match="torque: expected a dynamics.torques object"):
        torque_spec(lambda t, q, v: q)


@pytest.mark.parametrize("payload, field, expected", [
    ({"torque": {"type": "pd", "q_target": [0], "kp": 1, "kd": 1, "gain": 2}}, "torque.pd.gain",
     "type, q_target, kp, kd, v_target, tau_ff"),
    ({"torque": {"type": "table", "t": [0], "tau": [0], "hld": "zoh"}}, "torque.table.hld", "type, t, tau, hold"),
    ({"torqe": {"type": "zero"}}, "torqe", "locked, q0, v0, duration, torque, integrator"),
])
def test_a_nested_unknown_field_lists_its_siblings(payload, field, expected):
    body = {"q0": [0.0], "v0": [0.0], "duration": 1.0, **payload}
    with pytest.raises(InvalidInput) as e:
        schemas.validate(schemas.SimulateRequest, body)
    assert e.value.field == field
    assert e.value.detail.startswith(f"{field}: unknown field; expected one of {expected}")


def test_nested_unknown_field_over_http(client):
    robot = client.robot("planar-2r")
    with pytest.raises(ServiceError) as e:
        robot.simulate([0.0, 0.0], [0.0, 0.0], 0.1, torque={"type": "pd", "q_target": [0, 0], "kp": 1, "kd": 1,
                                                            "gain": 3})
    assert e.value.status == 422 and e.value.field == "torque.pd.gain"
    assert "expected one of type, q_target, kp, kd, v_target, tau_ff" in e.value.message


# -- item 9: the API documents ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def app_client(tmp_path_factory):
    with in_process_app(tmp_path_factory.mktemp("api-store")) as c:
        yield c


def _walk(node, path=""):
    """Every (path, schema object) of a JSON document."""
    if isinstance(node, dict):
        yield path, node
        for k, v in node.items():
            yield from _walk(v, f"{path}/{k}")
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _walk(v, f"{path}/{i}")


def test_every_request_has_an_example_that_works(app_client):
    doc = app_client.get("/openapi.json").json()
    posts = {path: op["post"] for path, op in doc["paths"].items()
             if "post" in op and "/jobs" not in path}  # (the jobs routes are another branch's)
    assert len(posts) >= 16
    for path, op in posts.items():
        body = op["requestBody"]["content"]["application/json"]
        example = body["example"]
        name = body["schema"]["$ref"].rsplit("/", 1)[1]
        assert doc["components"]["schemas"][name]["examples"] == [example], path
        if path.endswith("/simulate"):  # needs a worker process: test_simulate_example_works
            continue
        r = app_client.post(path.replace("{robot_id}", "planar-2r"), json=example)
        assert r.status_code in (200, 201), (path, r.text)


def test_answers_are_typed(app_client):
    doc = app_client.get("/openapi.json").json()
    untyped = [p for p, node in _walk(doc) if node.get("items") == {} or node.get("type") == "array"
               and "items" not in node and "prefixItems" not in node]
    assert untyped == []
    for path, op in doc["paths"].items():
        if "/jobs" in path:  # (the jobs routes are another branch's; they document their own answers)
            continue
        for method, spec in op.items():
            ok = spec["responses"].get("200") or spec["responses"].get("201") or spec["responses"].get("204")
            assert ok is not None, (path, method)
            if "content" in ok:
                schema = ok["content"]["application/json"]["schema"]
                assert "$ref" in schema, (path, method, schema)  # a named answer model, not {}
    jac = doc["components"]["schemas"]["JacobianAnswer"]["properties"]["jacobian"]
    assert jac["anyOf"][0] == {"type": "array", "items": {"type": "array", "items": {"type": "number"}}}


def test_docs_work_offline(app_client):
    for page, assets in (("/docs", ("swagger-ui-bundle.js", "swagger-ui.css")), ("/redoc", ("redoc.standalone.js",))):
        html = app_client.get(page)
        assert html.status_code == 200
        assert "cdn" not in html.text.lower() and "https://" not in html.text.replace("https://fastapi", "")
        for asset in assets:
            url = f"/static-offline-docs/{asset}"
            assert url in html.text
            r = app_client.get(url)
            assert r.status_code == 200 and len(r.content) > 10_000, asset
    assert "/openapi.json" in app_client.get("/docs").text


def test_simulate_example_works(server):
    example = schemas.SimulateRequest.model_config["json_schema_extra"]["examples"][0]
    r = while_simulation_starts(lambda: _post_or_raise(f"{server.url}/v1/robots/planar-2r/simulate", example))
    assert r["report"]["status"] == "ok" and len(r["t"]) == 101


def _post_or_raise(url, body):
    r = httpx.post(url, json=body, timeout=120)
    if r.status_code != 200:
        raise ServiceError(r.status_code, r.text)
    return r.json()
