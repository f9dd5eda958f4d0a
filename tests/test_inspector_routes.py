"""The inspector's routes without a browser: its files are served from this package and the installed meshcat,
open without a key (code, no data) while its data route and the trajectory need one, nothing of it is loaded
before /inspect is asked for, and ``dynamics view`` starts a service and opens the right address."""

from __future__ import annotations

import json
import subprocess
import sys

import httpx
import numpy as np
import pytest

import dynamics
from dynamics import cli
from robots import ALL_TYPES, random_urdf
from service.routes import inspect as inspect_routes
from service_fixtures import in_process_app

KEY = "inspector-test-key"


@pytest.fixture(scope="module")
def keyed(tmp_path_factory):
    with in_process_app(tmp_path_factory.mktemp("store"), api_keys=(KEY,)) as client:
        yield client


def test_the_page_and_its_files_are_open_and_the_data_is_keyed(keyed):
    for path in ("/inspect", "/inspect/planar_2r", "/inspect/static/inspector.js", "/inspect/static/plots.js",
                 "/inspect/static/inspector.css", "/inspect/lib/meshcat.js"):
        r = keyed.get(path)
        assert r.status_code == 200, (path, r.text[:200])
    page = keyed.get("/inspect/planar_2r").text
    assert "/inspect/lib/meshcat.js" in page and "http" not in page.split("<body>")[1]  # nothing from elsewhere
    assert "THREE" in keyed.get("/inspect/lib/meshcat.js").text
    for path in ("/inspect/trajectory", "/v1/robots/planar_2r/inspect", "/inspector", "/inspect/../v1/robots"):
        assert keyed.get(path).status_code in (401, 404), path
    assert keyed.get("/inspect/trajectory").status_code == 401
    assert keyed.get("/inspect/static/app.py").status_code == 404


def test_the_data_route_is_the_library_s(keyed):
    doc = keyed.get("/v1/robots/planar_2r/inspect", headers={"Authorization": f"Bearer {KEY}"}).json()
    model = dynamics.load_urdf(str(__import__("service_fixtures").ROBOTS / "planar_2r.urdf"))
    checks = dynamics.check_inertias(model)
    assert [b["name"] for b in doc["bodies_inspected"]] == list(model.body_names)
    for b, c, axis, X in zip(doc["bodies_inspected"], checks, model.axes, model.placements):
        np.testing.assert_array_equal(b["box"], c.box)
        np.testing.assert_array_equal(b["principal_moments"], c.principal_moments)
        np.testing.assert_array_equal(b["axis"], axis)
        np.testing.assert_array_equal(b["placement"], X)
        assert b["verdict"] == "ok"
    assert doc["collision_geometry"] == [] and doc["joint_names"] == list(model.joint_names)


def test_the_data_route_carries_the_model_s_neutral_configuration(keyed):
    """Random trees with every joint type, on a fixed and on a floating base: the description the page reads
    carries the model's own neutral configuration (identity quaternions, a planar joint's (cos, sin) = (1, 0),
    1-dof joints within their limits), and forward kinematics is answered there, as the library computes it."""
    auth = {"Authorization": f"Bearer {KEY}"}
    rng = np.random.default_rng(48)
    types = set()
    for n, floating in enumerate((False, True, False, True)):
        text = random_urdf(rng, n_links=7, types=ALL_TYPES, name=f"neutral{n}")
        model = dynamics.load_urdf(text, floating_base=floating)
        types.update(model.joint_types)
        r = keyed.post("/v1/robots", params={"floating_base": str(floating).lower()}, content=text,
                       headers={**auth, "Content-Type": "application/xml"})
        assert r.status_code in (200, 201), r.text
        rid = r.json()["id"]
        doc = keyed.get(f"/v1/robots/{rid}/inspect", headers=auth).json()
        np.testing.assert_array_equal(doc["neutral"], model.neutral())
        fk = keyed.post(f"/v1/robots/{rid}/kinematics", json={"q": doc["neutral"]}, headers=auth)
        assert fk.status_code == 200, fk.text
        np.testing.assert_allclose(fk.json()["placements"], dynamics.forward_kinematics(model, model.neutral()),
                                   atol=1e-12)
    assert {"spherical", "planar", "floating"} <= types  # (the trees drawn hold the joints the issue was about)


def test_the_api_routes_come_first_and_nothing_is_loaded_before_use():
    """Starlette tries routes in order: every API route before the page's, so no API request is matched against
    them; and building the app imports neither meshcat nor reads a page file."""
    code = ("import sys; from service.app import create_app; from service.settings import Settings; "
            "app = create_app(Settings(sim_workers=0)); "
            "flat = lambda r: [getattr(x, 'path', '') for x in r.original_router.routes] "
            "if hasattr(r, 'original_router') else [getattr(r, 'path', '')]; "
            "paths = [p for r in app.router.routes for p in flat(r)]; "
            "first = min(i for i, p in enumerate(paths) if p.startswith('/inspect')); "
            "assert all(not p.startswith('/v1') for p in paths[first:]), paths; "
            "assert 'meshcat' not in sys.modules; print('ok')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "ok", out.stderr[-2000:]


def test_dynamics_view_starts_a_service_and_opens_the_robot_with_its_trajectory(tmp_path, monkeypatch):
    model = dynamics.load_urdf(str(__import__("service_fixtures").ROBOTS / "planar_2r.urdf"))
    t = np.linspace(0, 1, 5)
    q = np.outer(t, [0.1, -0.2])
    np.savez(tmp_path / "run.npz", t=t, q=q, v=np.zeros_like(q), tau=np.zeros_like(q),
             report=json.dumps({"status": "ok", "integrator": "rk45"}))
    monkeypatch.setenv("DYNAMICS_SIM_WORKERS", "0")
    monkeypatch.setenv("DYNAMICS_JOB_WORKERS", "0")
    monkeypatch.setenv("DYNAMICS_ROBOTS_DIR", str(__import__("service_fixtures").ROBOTS))
    seen = {}

    def browser_open(url):  # what a browser would load first: the page and the trajectory it was handed
        seen["url"] = url
        base = url.split("/inspect/")[0]
        seen["page"] = httpx.get(url).status_code
        seen["trajectory"] = httpx.get(base + "/inspect/trajectory").json()
        return True

    monkeypatch.setattr(cli.webbrowser, "open", browser_open)
    monkeypatch.setattr(cli, "_wait", lambda: None)  # (instead of waiting for Ctrl-C)
    assert cli.main(["view", "planar_2r", "--trajectory", str(tmp_path / "run.npz")]) == 0
    assert seen["url"].startswith("http://127.0.0.1:") and seen["url"].endswith("/inspect/planar_2r?trajectory=1")
    assert seen["page"] == 200
    np.testing.assert_array_equal(seen["trajectory"]["q"], q)
    assert seen["trajectory"]["report"]["integrator"] == "rk45"
    with pytest.raises(httpx.TransportError):  # stopped once the command returned
        httpx.get(seen["url"], timeout=2)
    assert model.nq == 2


def test_dynamics_view_on_a_running_service_opens_its_address(monkeypatch, capsys):
    seen = []
    monkeypatch.setattr(cli.webbrowser, "open", seen.append)
    assert cli.main(["view", "pendulum", "--url", "http://example.test:9000/"]) == 0
    assert seen == ["http://example.test:9000/inspect/pendulum"]
    assert cli.main(["view", "pendulum", "--url", "http://x", "--trajectory", "run.npz"]) == 1
    assert "--trajectory" in capsys.readouterr().err


def test_a_trajectory_file_becomes_json_without_nan(tmp_path):
    t = np.array([0.0, 0.1])
    q = np.array([[0.1, np.nan], [np.inf, 0.2]])
    np.savez(tmp_path / "run.npz", t=t, q=q, report=json.dumps({"status": "NaN in the state", "x": float("nan")}))
    doc = json.loads(cli._trajectory_json(tmp_path / "run.npz"))
    assert doc["q"] == [[0.1, None], [None, 0.2]] and doc["t"] == [0.0, 0.1]
    assert doc["report"] == {"status": "NaN in the state", "x": None}
    np.savez(tmp_path / "bad.npz", x=t)
    assert cli.main(["view", "pendulum", "--trajectory", str(tmp_path / "bad.npz")]) == 1
