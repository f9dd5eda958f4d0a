"""The HTTP service through raw HTTP against a real uvicorn process: numbers, errors, hostile input, limits.

Numbers are compared with the library called in this process on the same URDF (exact equality: same code,
same inputs, float64 through JSON's shortest round-trip repr or .npz).
"""

from __future__ import annotations

import io
import json
import socket
import threading
import time
import zipfile
from concurrent.futures import ThreadPoolExecutor

import httpx
import numpy as np
import pytest

import dynamics
from service_fixtures import ROBOTS, shared_server

NPZ = "application/x-npz"
JSON_H = {"Content-Type": "application/json"}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    return shared_server(tmp_path_factory.getbasetemp())


@pytest.fixture(scope="module")
def http(server):
    with httpx.Client(base_url=server.url, timeout=60) as c:
        yield c


@pytest.fixture(scope="module")
def puma():
    return dynamics.load_urdf(str(ROBOTS / "puma560.urdf"))


def post(http, path, payload, **kw):
    return http.post(path, content=json.dumps(payload), headers=JSON_H, **kw)


def npz_bytes(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def read_npz(content: bytes) -> dict:
    with np.load(io.BytesIO(content), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def states(model, B, seed=0):
    rng = np.random.default_rng(seed)
    shape = (model.nq,) if B is None else (B, model.nq)
    return rng.uniform(-2, 2, shape), rng.normal(size=shape), rng.normal(size=shape)


# -- basics -------------------------------------------------------------------------------------------------------
def test_health_list_and_info(http):
    assert http.get("/v1/health").json() == {"status": "ok"}
    listed = {r["id"]: r for r in http.get("/v1/robots").json()["robots"]}
    for stem in ("planar_2r", "pendulum", "rp_arm", "planar_3r", "puma560"):
        if (ROBOTS / f"{stem}.urdf").exists():
            assert listed[stem]["bundled"] is True
    info = http.get("/v1/robots/planar-2r").json()
    assert (info["nq"], info["nv"], info["joint_names"]) == (2, 2, ["joint1", "joint2"])
    j1 = info["joints"][0]
    assert j1["type"] == "revolute" and j1["parent"] is None and j1["effort_limit"] == [500.0]
    assert j1["lower"] == [pytest.approx(-np.pi)] and j1["damping"] == [0.0]
    assert info["joints"][1]["parent"] == "link1"
    doc = http.get("/openapi.json").json()
    assert "/v1/robots/{robot_id}/simulate" in doc["paths"] and "InverseDynamicsRequest" in doc["components"]["schemas"]
    assert http.get("/docs").status_code == 200


@pytest.mark.parametrize("batch", [None, 5])
def test_every_endpoint_matches_the_library_json(http, puma, batch):
    q, v, a = states(puma, batch)
    g = np.array([0.3, -1.0, -9.0])
    cases = [
        ("inverse-dynamics", {"q": q, "v": v, "a": a}, "tau", dynamics.inverse_dynamics(puma, q, v, a)),
        ("inverse-dynamics", {"q": q, "v": v, "a": a, "gravity": g}, "tau",
         dynamics.inverse_dynamics(puma, q, v, a, gravity=g)),
        ("forward-dynamics", {"q": q, "v": v, "tau": a}, "a", dynamics.forward_dynamics(puma, q, v, a)),
        ("mass-matrix", {"q": q}, "mass_matrix", dynamics.mass_matrix(puma, q)),
        ("gravity-torques", {"q": q}, "tau", dynamics.gravity_torques(puma, q)),
        ("bias-forces", {"q": q, "v": v}, "tau", dynamics.bias_forces(puma, q, v)),
    ]
    for path, args, key, expected in cases:
        r = post(http, f"/v1/robots/puma560/{path}", {k: x.tolist() for k, x in args.items()})
        assert r.status_code == 200, r.text
        got = np.asarray(r.json()[key])
        assert got.shape == expected.shape and np.array_equal(got, expected), path


def test_f_ext(http, puma):
    q, v, a = states(puma, None)
    f = np.random.default_rng(1).normal(size=(puma.nbodies, 6))
    r = post(http, "/v1/robots/puma560/inverse-dynamics", {"q": q.tolist(), "v": v.tolist(), "a": a.tolist(),
                                                          "f_ext": f.tolist()})
    assert np.array_equal(r.json()["tau"], dynamics.inverse_dynamics(puma, q, v, a, f_ext=f))


def test_npz_both_ways_big_batch(http, puma):
    q, v, a = states(puma, 20_000, seed=3)
    r = http.post("/v1/robots/puma560/inverse-dynamics", content=npz_bytes(q=q, v=v, a=a),
                  headers={"Content-Type": NPZ, "Accept": NPZ})
    assert r.status_code == 200 and r.headers["content-type"] == NPZ
    assert np.array_equal(read_npz(r.content)["tau"], dynamics.inverse_dynamics(puma, q, v, a))
    # .npz in, JSON out (Accept decides)
    r = http.post("/v1/robots/puma560/mass-matrix", content=npz_bytes(q=q[:3]), headers={"Content-Type": NPZ})
    assert np.array_equal(r.json()["mass_matrix"], dynamics.mass_matrix(puma, q[:3]))


# -- errors name the field ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("payload, status, field, words", [
    ({"q": [[0.0] * 5] * 2, "v": [[0.0] * 6] * 2, "a": [[0.0] * 6] * 2}, 422, "q", "expected shape"),
    ({"q": [0.0] * 6, "v": [0.0] * 6}, 422, "a", "missing"),
    ({"q": [0.0] * 6, "v": [0.0] * 6, "a": [0.0] * 6, "lokced": {}}, 422, "lokced", "unknown field"),
    ({"q": [0.0] * 6, "v": [0.0] * 5 + [float("nan")], "a": [0.0] * 6}, 422, "v", "non-finite"),
    ({"q": [[0.0] * 6, [0.0] * 5], "v": [0.0] * 6, "a": [0.0] * 6}, 422, "q", "equal-length"),
    ({"q": "zeros", "v": [0.0] * 6, "a": [0.0] * 6}, 422, "q", "string"),
    ({"q": [[0.0] * 6] * 3, "v": [[0.0] * 6] * 2, "a": [[0.0] * 6] * 3}, 422, "v", "batch of 3"),
    ({"q": [0.0] * 6, "v": [0.0] * 6, "a": [0.0] * 6, "gravity": [0, 0]}, 422, "gravity", "(3,)"),
])
def test_bad_input_is_a_4xx_naming_the_field(http, payload, status, field, words):
    r = http.post("/v1/robots/puma560/inverse-dynamics", content=json.dumps(payload), headers=JSON_H)
    body = r.json()
    assert r.status_code == status, body
    assert body["field"] == field and body["detail"].startswith(field + ":") and words in body["detail"], body


def test_other_refusals(http):
    assert http.post("/v1/robots/nope/mass-matrix", json={"q": [0]}).status_code == 404
    assert http.get("/v1/robots/..%2F..%2Fetc%2Fpasswd").status_code == 404
    r = http.post("/v1/robots/puma560/mass-matrix", content=b"{not json", headers=JSON_H)
    assert r.status_code == 422 and r.json()["field"] == "body"
    r = http.post("/v1/robots/puma560/mass-matrix", content=b"q=1", headers={"Content-Type": "text/plain"})
    assert r.status_code == 415
    r = http.post("/v1/robots/puma560/mass-matrix", content=json.dumps([1, 2]), headers=JSON_H)
    assert r.status_code == 422
    # an .npz holding a pickle is refused, never unpickled
    buf = io.BytesIO()
    np.save(buf, np.array([{"x": 1}], dtype=object), allow_pickle=True)
    with zipfile.ZipFile(bomb := io.BytesIO(), "w") as zf:
        zf.writestr("q.npy", buf.getvalue())
    r = http.post("/v1/robots/puma560/mass-matrix", content=bomb.getvalue(), headers={"Content-Type": NPZ})
    assert r.status_code == 422 and "numeric" in r.json()["detail"]
    # a small compressed archive that unpacks to 256 MiB is refused from its directory, not inflated
    with zipfile.ZipFile(bomb := io.BytesIO(), "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("q.npy", b"\0" * (256 << 20))
    assert len(bomb.getvalue()) < 1 << 20
    r = http.post("/v1/robots/puma560/mass-matrix", content=bomb.getvalue(), headers={"Content-Type": NPZ})
    assert r.status_code == 413


def test_batch_and_dof_limits(http):
    r = http.post("/v1/robots/pendulum/mass-matrix", content=npz_bytes(q=np.zeros((200_001, 1))),
                  headers={"Content-Type": NPZ})
    assert r.status_code == 422 and "DYNAMICS_MAX_BATCH" in r.json()["detail"] and r.json()["field"] == "q"
    links = "".join(f'<link name="l{i}"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" '
                    f'ixz="0" iyz="0"/></inertial></link>' for i in range(130))
    joints = "".join(f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
                     f'<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
                     for i in range(1, 130))
    r = http.post("/v1/robots", content=f'<robot name="long">{links}{joints}</robot>',
                  headers={"Content-Type": "application/xml"})
    assert r.status_code == 422 and "DYNAMICS_MAX_DOF" in r.json()["detail"], r.text


def test_64_mib_body_is_refused_while_reading(server, http):
    before = server.rss_kib()
    big = b"{" + b" " * (64 << 20) + b"}"
    r = http.post("/v1/robots/puma560/inverse-dynamics", content=big, headers=JSON_H)
    assert r.status_code == 413 and r.json()["field"] == "body"

    def chunks():  # no Content-Length: the limit must bite while streaming
        for _ in range(64):
            yield b" " * (1 << 20)
    r = http.post("/v1/robots/puma560/inverse-dynamics", content=chunks(), headers=JSON_H)
    assert r.status_code == 413
    assert server.rss_kib() - before < 24 * 1024  # well under the 64 MiB sent, twice
    assert http.get("/v1/health").status_code == 200


# -- uploads ------------------------------------------------------------------------------------------------------
def test_upload_same_content_same_id_then_delete(http):
    text = (ROBOTS / "rp_arm.urdf").read_text()
    r1 = http.post("/v1/robots", content=text, headers={"Content-Type": "application/xml"},
                   params={"name": "my-arm"})
    r2 = http.post("/v1/robots", json={"urdf": text, "name": "my-arm"})
    assert r1.status_code == 201 and r2.status_code == 200, r1.text  # the same robot again: 200, same id
    assert r1.json()["id"] == r2.json()["id"] and r1.headers["location"] == f"/v1/robots/{r1.json()['id']}"
    r = http.post("/v1/robots", json={"urdf": text, "name": "my-arm", "floating_base": True})
    assert r.status_code == 409 and r.json()["field"] == "name"  # names are unique per key
    r3 = http.post("/v1/robots", json={"urdf": text, "name": "my-arm-floating", "floating_base": True})
    assert r3.status_code == 201 and r3.json()["id"] != r1.json()["id"] and r3.json()["nq"] == 7 + 2
    rid = r1.json()["id"]
    model = dynamics.load_urdf(text)
    q = np.array([0.3, 0.1])
    r = http.post(f"/v1/robots/{rid}/gravity-torques", json={"q": q.tolist()})
    assert np.array_equal(r.json()["tau"], dynamics.gravity_torques(model, q))
    for r in (r1, r3):
        assert http.delete(f"/v1/robots/{r.json()['id']}").status_code == 204
    assert http.get(f"/v1/robots/{rid}").status_code == 404
    assert http.post(f"/v1/robots/{rid}/gravity-torques", json={"q": q.tolist()}).status_code == 404
    assert http.delete("/v1/robots/planar-2r").status_code == 403


class Listener:
    """A loopback TCP listener that records whether anybody connected (nobody should)."""

    def __init__(self):
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.connections = 0
        self._stop = False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        while not self._stop:
            try:
                conn, _ = self.sock.accept()
                self.connections += 1
                conn.close()
            except OSError:
                pass

    def close(self):
        self._stop = True
        self.thread.join()
        self.sock.close()


ARM = """<robot name="arm">
  <link name="base"/>
  <link name="l1"><inertial><mass value="{mass}"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>
  </inertial>{visual}</link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  {extra}
</robot>"""


def arm(mass="1.0", visual="", extra=""):
    return ARM.format(mass=mass, visual=visual, extra=extra)


def test_hostile_urdfs_are_refused_and_open_nothing(http):
    lis = Listener()
    url = f"http://127.0.0.1:{lis.port}/x"
    laughs = ('<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol "lol">'
              + "".join(f'<!ENTITY lol{i} "{("&lol%s;" % (i - 1 if i else "")) * 10}">' for i in range(1, 10))
              + ']><robot name="&lol9;"><link name="a"/></robot>')
    cases = {
        "billion laughs": (laughs, "DOCTYPE"),
        "external entity (file)": ('<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
                                   '<robot name="&x;"><link name="a"/></robot>', "DOCTYPE"),
        "external entity (url)": (f'<!DOCTYPE r [<!ENTITY x SYSTEM "{url}">]><robot name="&x;"><link name="a"/>'
                                  '</robot>', "DOCTYPE"),
        "truncated": (arm()[:200], "well-formed"),
        "not a robot": ('<html><body/></html>', "robot"),
        "negative mass": (arm(mass="-2"), "l1"),
        "two parents": (arm(extra='<link name="l2"/><joint name="j2" type="fixed"><parent link="base"/>'
                                  '<child link="l1"/></joint>'), "l1"),
        "deep": ('<robot name="d">' + "<a>" * 200 + "</a>" * 200 + "</robot>", "deeper"),
    }
    try:
        for what, (doc, words) in cases.items():
            r = http.post("/v1/robots", content=doc, headers={"Content-Type": "application/xml"})
            assert r.status_code == 422, (what, r.text)
            body = r.json()
            assert body["field"] == "urdf" and words in body["detail"], (what, body)
        # a path instead of a document is refused, not read
        r = http.post("/v1/robots", json={"urdf": str(ROBOTS / "puma560.urdf")})
        assert r.status_code == 422 and r.json()["field"] == "urdf"
        # meshes named inside are never fetched or opened: the robot loads, the listener sees nobody
        visual = (f'<visual><geometry><mesh filename="{url}/m.stl"/></geometry></visual>'
                  '<collision><geometry><mesh filename="file:///dev/zero"/></geometry></collision>')
        r = http.post("/v1/robots", content=arm(visual=visual), headers={"Content-Type": "application/xml"})
        assert r.status_code == 201, r.text
        http.delete(f"/v1/robots/{r.json()['id']}")
        time.sleep(0.3)
        assert lis.connections == 0
    finally:
        lis.close()


# -- concurrency --------------------------------------------------------------------------------------------------
def test_8_threads_x_100_requests_identical(server, puma):
    rng = np.random.default_rng(7)
    work = []
    for i in range(16):
        q, v, a = states(puma, None if i % 2 else 4, seed=i)
        path, payload, key, ref = [
            ("inverse-dynamics", {"q": q, "v": v, "a": a}, "tau", dynamics.inverse_dynamics(puma, q, v, a)),
            ("forward-dynamics", {"q": q, "v": v, "tau": a}, "a", dynamics.forward_dynamics(puma, q, v, a)),
            ("mass-matrix", {"q": q}, "mass_matrix", dynamics.mass_matrix(puma, q)),
            ("bias-forces", {"q": q, "v": v}, "tau", dynamics.bias_forces(puma, q, v)),
        ][i % 4]
        work.append((path, json.dumps({k: x.tolist() for k, x in payload.items()}), key, ref))

    def worker(t):
        failures = 0
        with httpx.Client(base_url=server.url, timeout=60) as c:
            for n in range(100):
                path, body, key, ref = work[(t * 100 + n + int(rng.integers(0, 1))) % len(work)]
                r = c.post(f"/v1/robots/puma560/{path}", content=body, headers=JSON_H)
                if r.status_code != 200 or not np.array_equal(r.json()[key], ref):
                    failures += 1
        return failures

    with ThreadPoolExecutor(8) as pool:
        assert sum(pool.map(worker, range(8))) == 0
