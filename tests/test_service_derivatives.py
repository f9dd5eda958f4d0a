"""The derivative endpoints (issue 20, section 4): ``POST /v1/robots/{id}/derivatives/inverse_dynamics`` and
``/forward_dynamics`` and ``/constrained_forward_dynamics``, one state or a batch, JSON and .npz, the answer-size
limit and the refusals.

Every number is compared bit for bit with the library called here on the same model (the library itself is
checked against Pinocchio and finite differences in tests/test_derivatives.py).  The in-process app covers the
endpoints; the client methods run against the real server shared with the other service tests.
"""

from __future__ import annotations

import io
import json

import numpy as np
import pytest

import dynamics
from service.client import Client
from service_fixtures import ROBOTS, in_process_app, shared_server
from test_service_kinematics import random_state

OPS = {"inverse_dynamics": (("q", "v", "a"), ("dtau_dq", "dtau_dv", "mass_matrix"),
                            dynamics.inverse_dynamics_derivatives),
       "forward_dynamics": (("q", "v", "tau"), ("da_dq", "da_dv", "inverse_mass_matrix"),
                            dynamics.forward_dynamics_derivatives)}


@pytest.fixture(scope="module")
def app_client(tmp_path_factory):
    with in_process_app(tmp_path_factory.mktemp("deriv-store"), max_json_answer_bytes=21 * 20_000) as c:
        yield c


@pytest.fixture(scope="module")
def puma():
    return dynamics.load_urdf(str(ROBOTS / "puma560.urdf"))


def states(model, rng, batch=None):
    q, v = random_state(model, rng, batch)
    return q, v, rng.normal(size=v.shape)


@pytest.mark.parametrize("op", list(OPS))
@pytest.mark.parametrize("batch", [None, 5])
def test_json_answers_are_the_library_s(app_client, puma, op, batch):
    names, keys, function = OPS[op]
    q, v, x = states(puma, np.random.default_rng(1), batch)
    f_ext = np.random.default_rng(2).normal(size=(puma.nbodies, 6))
    body = dict(zip(names, (q.tolist(), v.tolist(), x.tolist())), f_ext=f_ext.tolist(), gravity=[0.0, 1.0, -9.0])
    r = app_client.post(f"/v1/robots/puma560/derivatives/{op}", json=body)
    assert r.status_code == 200, r.text
    ans = r.json()
    expected = function(puma, q, v, x, f_ext=f_ext, gravity=np.array([0.0, 1.0, -9.0]))
    for key, ref in zip(keys, expected):
        assert np.array_equal(ans[key], ref), key
    assert ans["scene"]["nv"] == puma.nv


@pytest.mark.parametrize("op", list(OPS))
def test_npz_both_ways(app_client, puma, op):
    names, keys, function = OPS[op]
    q, v, x = states(puma, np.random.default_rng(3), 200)
    buf = io.BytesIO()
    np.savez(buf, **dict(zip(names, (q, v, x))))
    r = app_client.post(f"/v1/robots/puma560/derivatives/{op}", content=buf.getvalue(),
                        headers={"Content-Type": "application/x-npz", "Accept": "application/x-npz"})
    assert r.status_code == 200, r.text
    with np.load(io.BytesIO(r.content), allow_pickle=False) as npz:
        for key, ref in zip(keys, function(puma, q, v, x)):
            assert np.array_equal(npz[key], ref), key


def test_an_answer_over_the_limit_is_refused_before_any_work(app_client):
    """200 states of three 6x6 matrices are 21,600 numbers: over the 20,000 of this app's JSON limit."""
    r = app_client.post("/v1/robots/puma560/derivatives/inverse_dynamics",
                        json={"q": [[0.1] * 6] * 200, "v": [0.0] * 6, "a": [0.0] * 6})
    assert r.status_code == 413, r.text
    assert r.json()["field"] == "answer" and "DYNAMICS_MAX_JSON_ANSWER_BYTES" in r.json()["detail"]


@pytest.mark.parametrize("op, payload, field, words", [
    ("inverse_dynamics", {"v": [0.0] * 5}, "v", ["(6,)"]),
    ("forward_dynamics", {"tau": [float("nan")] * 6}, None, []),
    ("forward_dynamics", {"f_ext": [[0.0] * 6] * 2}, "f_ext", ["(6, 6)"]),
    ("inverse_dynamics", {"qdd": [0.0] * 6}, "qdd", ["unknown field"]),
    ("inverse_dynamics", {"q": [[0.1] * 6] * 3, "v": [[0.0] * 6] * 2}, None, ["3", "2"]),
])
def test_bad_input_is_a_422_naming_the_field(app_client, op, payload, field, words):
    names = OPS[op][0]
    body = {**{n: [0.1] * 6 for n in names}, **payload}
    r = app_client.post(f"/v1/robots/puma560/derivatives/{op}", content=json.dumps(body, allow_nan=True),
                        headers={"Content-Type": "application/json"})
    assert r.status_code == 422, r.text
    if field is not None:
        assert r.json()["field"] == field
    for w in words:
        assert w in r.json()["detail"]


def test_client_methods_have_the_library_names(tmp_path_factory, puma):
    with Client(shared_server(tmp_path_factory.getbasetemp()).url) as client:
        robot = client.robot("puma560")
        rng = np.random.default_rng(4)
        for batch in (None, 3):
            q, v, x = states(puma, rng, batch)
            for got, ref in zip(robot.inverse_dynamics_derivatives(q, v, x),
                                dynamics.inverse_dynamics_derivatives(puma, q, v, x)):
                assert np.array_equal(got, ref)
            for got, ref in zip(robot.forward_dynamics_derivatives(q, v, x),
                                dynamics.forward_dynamics_derivatives(puma, q, v, x)):
                assert np.array_equal(got, ref)
            for got, ref in zip(robot.constrained_forward_dynamics_derivatives(q, v, x),
                                dynamics.forward_dynamics_derivatives(puma, q, v, x)):  # (no constraints)
                assert np.array_equal(got, ref)


def _four_bar_states(batch):
    fb = dynamics.load_urdf(str(ROBOTS / "four_bar.urdf"))
    Q = np.array([dynamics.assemble(fb, [c, 0.5, 1.5], fixed=["theta1"]) for c in (0.1, 0.7, 1.3)])
    V = dynamics.project_velocity(fb, Q, np.tile([1.0, 0.0, 0.0], (3, 1)))
    T = np.random.default_rng(5).normal(size=(3, fb.nv))
    return (fb, Q, V, T) if batch else (fb, Q[1], V[1], T[1])


@pytest.mark.parametrize("batch", [False, True])
def test_constrained_derivatives_are_the_library_s(app_client, batch):
    """The four-bar's six blocks (JSON one state with Baumgarte, .npz a batch) bit for bit; a robot without
    constraints answers the ABA's derivatives with no multiplier rows."""
    fb, q, v, tau = _four_bar_states(batch)
    baumgarte = None if batch else (5.0, 8.0)  # (an .npz body carries arrays only)
    expected = dynamics.constrained_forward_dynamics_derivatives(fb, q, v, tau, baumgarte=baumgarte)
    keys = ("da_dq", "da_dv", "da_dtau", "dlambda_dq", "dlambda_dv", "dlambda_dtau")
    url = "/v1/robots/four-bar/derivatives/constrained_forward_dynamics"
    if batch:
        buf = io.BytesIO()
        np.savez(buf, q=q, v=v, tau=tau)
        r = app_client.post(url, content=buf.getvalue(),
                            headers={"Content-Type": "application/x-npz", "Accept": "application/x-npz"})
        assert r.status_code == 200, r.text
        with np.load(io.BytesIO(r.content), allow_pickle=False) as npz:
            ans = {k: npz[k] for k in keys}
    else:
        r = app_client.post(url, json={"q": q.tolist(), "v": v.tolist(), "tau": tau.tolist(), "baumgarte": [5.0, 8.0]})
        assert r.status_code == 200, r.text
        ans = r.json()
        assert ans["scene"]["nv"] == fb.nv
    for key, ref in zip(keys, expected):
        assert np.array_equal(ans[key], ref) and np.shape(ans[key]) == ref.shape, key
    assert expected[3].shape[-2:] == (fb.info["constraints"]["rows"], fb.nv)
    puma = dynamics.load_urdf(str(ROBOTS / "puma560.urdf"))
    q, v, x = states(puma, np.random.default_rng(6), 3 if batch else None)
    r = app_client.post("/v1/robots/puma560/derivatives/constrained_forward_dynamics",
                        json={"q": q.tolist(), "v": v.tolist(), "tau": x.tolist()})
    assert r.status_code == 200, r.text
    for got, ref in zip([r.json()[k] for k in keys[:3]], dynamics.forward_dynamics_derivatives(puma, q, v, x)):
        assert np.array_equal(got, ref)
    assert np.size(r.json()["dlambda_dq"]) == 0  # (JSON: [] for one state, B empty lists for a batch)
