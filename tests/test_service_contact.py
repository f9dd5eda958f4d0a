"""Contact in the service (issue 19, section 4): a ball of radius 0.1 m and 1 kg uploaded with a floating base,
dropped on the ground through ``/simulate``, a ``simulate_many`` job and the client; its collision geometry in
``GET /v1/robots/{id}``; clear 4xx for bad geometry.

References: free fall z(t) = z0 - g t^2 / 2 before the touch-down, and at rest the library's documented default
material (a contact carrying the whole weight sinks the penetration allowance, 1 mm: k = m g / delta), so the
resting ball presses with m g at depth delta.
"""

from __future__ import annotations

import io
import json
import math
import time

import httpx
import numpy as np
import pytest

import dynamics
from service.client import Client, ServiceError
from service_fixtures import Server, shared_server, while_simulation_starts

RADIUS, MASS, G = 0.1, 1.0, 9.81
INERTIA = 0.4 * MASS * RADIUS ** 2
BALL = (f'<robot name="contact-ball"><link name="ball"><inertial><mass value="{MASS}"/><inertia ixx="{INERTIA}" '
        f'iyy="{INERTIA}" izz="{INERTIA}" ixy="0" ixz="0" iyz="0"/></inertial><collision><origin xyz="0 0 0"/>'
        f'<geometry><sphere radius="{RADIUS}"/></geometry></collision></link></robot>')
Z0 = 0.5  # the centre's height at t = 0: a 0.4 m fall, touch-down at sqrt(0.8 / g) = 0.286 s
DROP = {"duration": 1.0, "sample_dt": 0.01, "rtol": 1e-9, "atol": 1e-11}
CONTACT = {"friction": 0.5, "outputs": ["contacts"]}
GEOMETRY = "ball/collision0"  # the library's name of the link's first <collision>


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    return shared_server(tmp_path_factory.getbasetemp())


@pytest.fixture(scope="module")
def client(server):
    with Client(server.url, timeout=600) as c:
        yield c


@pytest.fixture(scope="module")
def ball(client):
    return client.upload(BALL.encode(), name="contact-ball", floating_base=True)


def q0(z=Z0):
    return [0.0, 0.0, z, 0.0, 0.0, 0.0, 1.0]


def post(server, robot_id, body, **kw):
    return httpx.post(f"{server.url}/v1/robots/{robot_id}/simulate", json=body, timeout=300, **kw)


@pytest.fixture(scope="module")
def drop(server, ball):
    """The ball dropped from Z0 (one simulation)."""
    body = {"q0": q0(), "v0": [0.0] * 6, **DROP, "contact": CONTACT}

    def go():
        r = post(server, ball.id, body)
        if r.status_code in (503, 504):
            raise ServiceError(r.status_code, r.text)
        return r
    r = while_simulation_starts(go)
    assert r.status_code == 200, r.text
    return r.json()


def test_robot_lists_its_collision_geometry(client, ball):
    info = client.request("GET", f"/v1/robots/{ball.id}").json()
    (g,) = info["collision_geometry"]
    assert (g["name"], g["body"], g["frame"], g["kind"]) == (GEOMETRY, "ball", "ball", "sphere")
    assert g["size"] == [RADIUS, 0.0, 0.0] and np.array_equal(g["pose"], np.eye(4))
    assert client.request("GET", "/v1/robots/planar-2r").json()["collision_geometry"] == []  # (no <collision>)


def test_the_ball_falls_freely_then_rests_on_the_ground(drop):
    t, q = np.array(drop["t"]), np.array(drop["q"])
    falling = t < math.sqrt(2 * (Z0 - RADIUS) / G) - 0.01
    assert np.allclose(q[falling, 2], Z0 - 0.5 * G * t[falling] ** 2, rtol=0, atol=1e-8)
    # at rest: the normal forces carry m g, at the allowance's depth (1 mm: k = m g / delta)
    sample = np.array(drop["contacts.sample"])
    last = sample == len(t) - 1
    assert last.sum() == 1
    assert drop["contacts.pairs"][drop["contacts.pair"][-1]] == [GEOMETRY, "ground"]
    assert np.sum(np.array(drop["contacts.normal_force"])[last]) == pytest.approx(MASS * G, rel=1e-6)
    assert np.array(drop["contacts.depth"])[last][0] == pytest.approx(1e-3, rel=1e-6)
    assert q[-1, 2] == pytest.approx(RADIUS - 1e-3, abs=1e-8)
    assert np.allclose(np.array(drop["contacts.normal"])[last], [[0.0, 0.0, 1.0]])
    assert np.allclose(np.array(drop["contacts.point"])[last][0], [0.0, 0.0, -1e-3 / 2], atol=1e-6)
    assert (sample[1:] >= sample[:-1]).all() and not (t[sample] < falling.sum() * 0.01 - 1e-9).any()
    report = drop["report"]["contact"]
    assert report["max_penetration"] >= 1e-3 and 0.6 < report["time_in_contact"] <= 0.72


def test_the_client_sends_a_library_contact(ball, drop):
    contact = dynamics.Contact(friction=0.5, outputs=("contacts",))
    traj = while_simulation_starts(lambda: ball.simulate(q0(), np.zeros(6), contact=contact, **DROP))
    assert np.array_equal(traj.q, drop["q"])  # the same request as the dict's: the same answer, bit for bit
    assert [tuple(p) for p in traj.contacts["pairs"]] == [(GEOMETRY, "ground")]
    assert np.array_equal(traj.contacts["normal_force"], drop["contacts.normal_force"])
    plain = while_simulation_starts(lambda: ball.simulate(q0(), np.zeros(6), **DROP))
    assert plain.q[-1, 2] < -1.0 and plain.contacts is None and "contact" not in plain.report  # (no contact)


def test_a_declared_geometry_replaces_the_urdf_s(server, ball):
    """A sphere of 0.2 m declared on the ball's frame, on a ground at z = 0.3: it rests 0.5 m up."""
    body = {"q0": q0(0.6), "v0": [0.0] * 6, "duration": 0.5, "sample_dt": 0.5,
            "contact": {"ground": {"height": 0.3}, "geometries": [{"type": "sphere", "frame": "ball",
                                                                   "radius": 0.2, "name": "big"}],
                        "outputs": ["contacts"]}}
    r = while_simulation_starts(lambda: _ok(post(server, ball.id, body)))
    assert r["contacts.pairs"] == [["big", "ground"]]
    assert r["q"][-1][2] == pytest.approx(0.5 - 1e-3, abs=1e-5)


def _ok(r):
    if r.status_code in (503, 504):
        raise ServiceError(r.status_code, r.text)
    assert r.status_code == 200, r.text
    return r.json()


def test_a_simulate_many_job_runs_the_same_contact(client, ball, drop):
    heights = np.array([q0(), q0(0.3)])
    job = client.submit(ball, "simulate_many", {"q0": heights, "v0": np.zeros(6)},
                        options={**DROP, "contact": {"friction": 0.5}})
    assert job.wait(timeout=600)["status"] == "done", job.status()
    out = job.result()
    assert np.array_equal(out["q"][0], drop["q"])  # every run alone, as /simulate runs it
    assert out["q"][1][-1][2] == pytest.approx(RADIUS - 1e-3, abs=1e-8)
    reports = out["reports"] if isinstance(out["reports"], list) else json.loads(str(out["reports"]))
    assert len(reports) == 2 and all("contact" in r for r in reports)


BAD = [
    ({"geometries": [{"type": "sphere", "frame": "ball", "radius": -0.1}]}, "contact.geometries.0.sphere.radius"),
    ({"geometries": [{"type": "sphere", "radius": 0.1}]}, "contact.geometries[0].frame"),
    ({"geometries": [{"type": "sphere", "frame": "no_such_link", "radius": 0.1}]}, "contact.geometries"),
    ({"objects": [{"type": "box", "size": [1, 1, 1], "pose": [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0],
                                                              [0, 0, 0, 1]]}]}, "contact.objects[0]"),
    ({"objects": [{"type": "sphere", "frame": "ball", "radius": 1.0}]}, "contact.objects[0].frame"),
    ({"ground": {"normal": [0, 0, 0]}}, "contact.ground"),
    ({"materials": {"no_such_geometry": 0.3}}, "contact.materials"),
    ({"pairs": [["ball", "nowhere"]]}, "contact.pairs"),
    ({"friction": {"mu_static": 0.2, "mu_dynamic": 0.5}}, "contact.friction"),
    ({"pairs": [["ball", "ground"]] * 5000}, "contact.pairs"),
    ({"radius": 1.0}, "contact.radius"),
]


@pytest.mark.parametrize("contact, field", BAD, ids=[f for _, f in BAD])
def test_bad_contact_is_a_422_naming_the_field(server, ball, contact, field):
    body = {"q0": q0(), "v0": [0.0] * 6, "duration": 0.1, "contact": contact}
    r = while_simulation_starts(lambda: _status(post(server, ball.id, body)))
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert detail.startswith(field) and r.json()["field"].startswith(field.split("[")[0].split(".0")[0]), detail


def _status(r):
    if r.status_code in (503, 504):
        raise ServiceError(r.status_code, r.text)
    return r


def test_huge_lists_are_refused_by_their_size(server, ball):
    """A pair list of 10^6 entries, and a NaN pose (JSON has no NaN: .npz carries the contact as a JSON string),
    refused before anything is built."""
    pairs = {"q0": q0(), "v0": [0.0] * 6, "duration": 0.1, "contact": {"pairs": [["a", "b"]] * 1_000_000}}
    r = post(server, ball.id, pairs)
    assert r.status_code in (413, 422) and r.json()["field"] in ("body", "contact.pairs"), r.text
    small = {"q0": np.array(q0()), "v0": np.zeros(6), "duration": np.array(0.1),
             "contact": np.array('{"pairs": ' + json.dumps([["a", "b"]] * 1_000_000) + '}')}
    buf = io.BytesIO()
    np.savez_compressed(buf, **small)  # (a few kB compressed)
    r = httpx.post(f"{server.url}/v1/robots/{ball.id}/simulate", content=buf.getvalue(), timeout=60,
                   headers={"Content-Type": "application/x-npz"})
    assert r.status_code in (413, 422), r.text
    nan = '{"objects": [{"type": "box", "size": [1, 1, 1], "pose": [[1, 0, 0, NaN], [0, 1, 0, 0], [0, 0, 1, 0], ' \
          '[0, 0, 0, 1]]}]}'
    buf = io.BytesIO()
    np.savez(buf, q0=np.array(q0()), v0=np.zeros(6), duration=np.array(0.1), contact=np.array(nan))
    r = httpx.post(f"{server.url}/v1/robots/{ball.id}/simulate", content=buf.getvalue(), timeout=60,
                   headers={"Content-Type": "application/x-npz"})
    assert r.status_code == 422 and r.json()["field"].startswith("contact.objects.0.box.pose"), r.text


def test_a_job_refuses_bad_geometry_at_submission(client, ball):
    for contact, field in (({"geometries": [{"type": "box", "frame": "ball", "size": [1, 1, 0]}]},
                            "options.contact.geometries"),
                           ({"geometries": [{"type": "sphere", "frame": "no_such_link", "radius": 0.1}],
                             "outputs": ["contacts"]}, "options.contact.geometries[0].frame")):
        with pytest.raises(ServiceError) as e:
            client.submit(ball, "simulate_many", {"q0": np.array(q0()), "v0": np.zeros(6)},
                          options={"duration": 0.1, "contact": contact})
        assert e.value.status == 422 and e.value.field.startswith(field), str(e.value)


# -- the contacts per sample of simulate_many jobs ------------------------------------------------------------
FIELDS = ("point", "normal", "normal_force", "friction", "depth", "slip")


def library_runs(heights):
    """The library's simulate_many of the ball dropped from each height, with the job's options."""
    model = dynamics.load_urdf(BALL.encode(), floating_base=True, collision=True)
    q = np.array([q0(z) for z in heights])
    options = {k: v for k, v in DROP.items() if k != "duration"}
    return dynamics.simulate_many(model, q, np.zeros(6), DROP["duration"], progress=False,
                                  contact=dynamics.Contact(friction=0.5, outputs=("contacts",)), **options)


def library_rows(contacts, k):
    """Run k's active contacts, one row each in sample order, read off the library's stacked (B, T, K) arrays."""
    sample, row = np.nonzero(contacts.pair[k] >= 0)
    return {"sample": sample, "pair": contacts.pair[k][sample, row],
            **{name: getattr(contacts, name)[k][sample, row] for name in FIELDS}}


def assert_runs_equal(flat, contacts, runs):
    """The job's flat rows (``contacts.run``, ``contacts.sample``, ...: from JSON or .npz) are the library's runs
    ``runs``, bit for bit, in run then sample order."""
    expected = [library_rows(contacts, k) for k in runs]
    assert np.array_equal(np.asarray(flat["contacts.run"]),
                          np.concatenate([np.full(len(e["sample"]), run) for e, run in zip(expected, runs)]))
    for name in ("sample", "pair", *FIELDS):
        assert np.array_equal(np.asarray(flat[f"contacts.{name}"], dtype=expected[0][name].dtype),
                              np.concatenate([e[name] for e in expected])), name


HEIGHTS = [Z0, 6.0, 0.3, 0.15]  # the second falls 4.9 m in 1 s: it never touches (no rows between others')


def test_a_simulate_many_job_keeps_the_contacts_per_sample(server, client, ball, drop):
    job = client.submit(ball, "simulate_many", {"q0": np.array([q0(z) for z in HEIGHTS]), "v0": np.zeros(6)},
                        options={**DROP, "contact": CONTACT})
    assert job.wait(timeout=600)["status"] == "done", job.status()
    reference = library_runs(HEIGHTS).contacts
    out = job.result()  # the client: one dict per run, as Robot.simulate's contacts
    assert len(out["contacts"]) == len(HEIGHTS)
    for k, run in enumerate(out["contacts"]):
        assert run["pairs"] == [(GEOMETRY, "ground")]
        for name, value in library_rows(reference, k).items():
            assert np.array_equal(run[name], value), (k, name)
    assert len(out["contacts"][1]["sample"]) == 0 and len(out["contacts"][2]["sample"]) > 0
    assert np.array_equal(out["contacts"][0]["normal_force"], drop["contacts.normal_force"])  # as /simulate's
    assert np.array_equal(out["contacts"][0]["sample"], drop["contacts.sample"])
    last = out["contacts"][3]["sample"] == len(out["t"]) - 1  # at rest: the contact carries m g (module doc)
    assert out["contacts"][3]["normal_force"][last].sum() == pytest.approx(MASS * G, rel=1e-6)
    assert out["contacts"][3]["depth"][last][0] == pytest.approx(1e-3, rel=1e-6)

    url = f"{server.url}/v1/jobs/{job.id}/result"
    answer = httpx.get(url, headers={"Accept": "application/json"}, timeout=60)
    assert answer.headers["content-type"].startswith("application/json"), answer.headers
    body = answer.json()
    assert body["contacts.pairs"] == [[GEOMETRY, "ground"]]
    assert_runs_equal(body, reference, range(len(HEIGHTS)))  # (shortest round-trip floats: exact)
    answer = httpx.get(url, headers={"Accept": "application/x-npz"}, timeout=60)
    with np.load(io.BytesIO(answer.content), allow_pickle=False) as npz:
        assert json.loads(str(npz["contacts.pairs"])) == [[GEOMETRY, "ground"]]
        assert_runs_equal({k: npz[k] for k in npz.files}, reference, range(len(HEIGHTS)))


#: a result limit that a job of 120 drops from 0.15-0.6 m meets whatever its contacts (1.84 MB of states and at
#: most 101 contact rows of 128 bytes per run: 3.39 MB), and that 200 drops from 0.11 m (3.07 MB of states, within
#: it alone, and about 2.6 MB of contacts) pass
LIMIT = 4_000_000


def test_contacts_count_in_the_result_limit_and_survive_a_killed_server(tmp_path):
    env = {"DYNAMICS_MAX_JOB_RESULT_BYTES": str(LIMIT), "DYNAMICS_JOB_PART_SECONDS": "0.2"}
    server = Server(tmp_path / "store", env=env).start()
    try:
        client = Client(server.url, timeout=600)
        ball = client.upload(BALL.encode(), name="contact-ball", floating_base=True)
        options = {**DROP, "contact": CONTACT}
        small = client.submit(ball, "simulate_many", {"q0": np.array([q0(z) for z in HEIGHTS]), "v0": np.zeros(6)},
                              options=options)
        assert small.wait(timeout=600)["status"] == "done"
        heights = np.linspace(0.15, 0.6, 120)
        job = client.submit(ball, "simulate_many", {"q0": np.array([q0(z) for z in heights]), "v0": np.zeros(6)},
                            options=options)
        end = time.monotonic() + 600
        while not (0 < (before := job.status())["progress"]["done"] < 120 and before["status"] == "running"):
            assert time.monotonic() < end and before["status"] in ("queued", "running"), before
            time.sleep(0.05)
        server.kill()  # mid-job: parts with contact rows on disk, the rest to do
        server = Server(tmp_path / "store", env=env).start()
        client = Client(server.url, timeout=600)
        after = client.job(job.id).wait(timeout=600)
        assert after["status"] == "done" and after["attempts"] == 2 and "restarted" in after["error"], after
        reference = library_runs(heights).contacts
        answer = httpx.get(f"{server.url}/v1/jobs/{job.id}/result", headers={"Accept": "application/x-npz"},
                           timeout=60)
        with np.load(io.BytesIO(answer.content), allow_pickle=False) as npz:
            assert_runs_equal({k: npz[k] for k in npz.files}, reference, range(120))  # across the restart
        runs = client.job(small.id).result()["contacts"]  # finished before the crash: still served
        reference = library_runs(HEIGHTS).contacts
        assert all(np.array_equal(runs[k]["normal_force"], library_rows(reference, k)["normal_force"])
                   for k in range(len(HEIGHTS)))

        over = client.submit(ball, "simulate_many", {"q0": np.array([q0(0.11)] * 200), "v0": np.zeros(6)},
                             options=options)  # (accepted: its states alone are within the limit)
        info = over.wait(timeout=600)
        assert info["status"] == "failed", info
        assert info["error"].startswith("options.contact.outputs: the contacts per sample of runs 0-")
        assert f"over the limit of {LIMIT} bytes (DYNAMICS_MAX_JOB_RESULT_BYTES)" in info["error"], info
        with pytest.raises(ServiceError) as e:
            over.result()
        assert e.value.status == 409 and "DYNAMICS_MAX_JOB_RESULT_BYTES" in e.value.message
        assert not (tmp_path / "store" / "jobs" / "parts" / over.id).exists()  # its parts went with it
    finally:
        server.stop()
