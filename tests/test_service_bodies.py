"""Issue 49, findings 1 to 3: what a request body may cost before anything is checked.

1. A job's body: what needs no body (the key's job limit, its quota, the declared size, the media type) is refused
   before a byte of it is read; a JSON job body is at most the normal request limit (decoded, JSON numbers take
   ~15 times their text: a 255 MiB body took 4 GB); an .npz job body costs about the arrays it holds, measured
   as the server's peak RSS.
2. An .npz's members are counted and named before any is read: 36,000 empty members held a compute thread for
   14 s (and a normal request behind it), now they are refused at once.
3. numpy parses .npy headers with ``ast.literal_eval``, which CPython 3.11 cannot run in two threads at once
   (a rare 500 under load): headers are parsed one at a time, whatever the number of compute threads.

Against a real server (keys k1, k2, k3; one job per key at a time; a job quota of 160 MiB), but for finding 3,
which watches the parser inside an in-process app.
"""

from __future__ import annotations

import ast
import io
import json
import socket
import struct
import threading
import time
import zipfile

import httpx
import numpy as np
import pytest

import dynamics
from service.codec import NPZ
from service_fixtures import ROBOTS, Server, in_process_app

MiB = 1 << 20
JOB_QUOTA = 160 * MiB
#: a job long enough to be still queued or running when the next submission comes (seconds of simulate_many)
LONG = {"duration": 1.0, "integrator": "rk4", "dt": 1e-3, "sample_dt": 0.1, "error_estimate": "none"}


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    s = Server(tmp_path_factory.mktemp("bodies") / "store",
               env={"DYNAMICS_API_KEYS": "k1,k2,k3", "DYNAMICS_MAX_JOBS_PER_KEY": "1",
                    "DYNAMICS_JOB_QUOTA_BYTES": str(JOB_QUOTA), "DYNAMICS_READ_TIMEOUT": "5"}).start()
    yield s
    s.stop()


def client(server, key):
    return httpx.Client(base_url=server.url, timeout=300, headers={"Authorization": f"Bearer {key}"})


def npz_bytes(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def refused(r, status, field=None):
    assert r.status_code == status, (r.status_code, r.text[:500])
    body = r.json()
    if field is not None:
        assert body["field"] == field and body["detail"].startswith(field), body
    return body


def headers_only(server, key: str, content_type: str, length: int, timeout: float = 20.0) -> tuple[bytes, float]:
    """POST /v1/jobs declaring a body of ``length`` bytes and sending none: (the answer's head, seconds). A server
    that waits for the body answers only after its read timeout (5 s here), with a 408."""
    t = time.monotonic()
    with socket.create_connection(("127.0.0.1", server.port), timeout=timeout) as sock:
        sock.sendall(f"POST /v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {key}\r\nContent-Type: "
                     f"{content_type}\r\nContent-Length: {length}\r\n\r\n".encode())
        answer = b""
        while b"\r\n\r\n" not in answer:
            chunk = sock.recv(4096)
            if not chunk:
                break
            answer += chunk
    return answer, time.monotonic() - t


def rss_kib(server, field="VmRSS") -> int:
    with open(f"/proc/{server.proc.pid}/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    raise AssertionError(field)


def reset_peak(server) -> None:
    """The kernel's high-water mark of the server's RSS (VmHWM) set back to its RSS now (Linux: clear_refs 5)."""
    with open(f"/proc/{server.proc.pid}/clear_refs", "w") as f:
        f.write("5")


def cancel_all(c) -> None:
    for job in c.get("/v1/jobs").json()["jobs"]:
        c.delete(f"/v1/jobs/{job['id']}")


# -- finding 1: the cheap refusals first, and a job body's memory ----------------------------------------------
def test_a_key_at_its_job_limit_is_refused_before_its_body_is_read(server):
    model = dynamics.load_urdf(str(ROBOTS / "planar_3r.urdf"))
    q0 = np.random.default_rng(0).uniform(-1, 1, (3000, model.nq))
    with client(server, "k2") as c:
        r = c.post("/v1/jobs", content=npz_bytes(robot=np.array("planar_3r"), kind=np.array("simulate_many"),
                                                 options=np.array(json.dumps(LONG)), q0=q0, v0=np.zeros(model.nv)),
                   headers={"Content-Type": NPZ})
        assert r.status_code == 202, r.text
        try:
            answer, seconds = headers_only(server, "k2", NPZ, 200 * MiB)
            assert answer.startswith(b"HTTP/1.1 429"), answer[:300]
            assert seconds < 2.0  # not after the read timeout (5 s): no byte of the 200 MiB was awaited
        finally:
            cancel_all(c)


def test_a_body_over_the_key_s_quota_is_refused_before_it_is_read(server):
    answer, seconds = headers_only(server, "k3", NPZ, 200 * MiB)  # (under the 256 MiB input limit)
    assert answer.startswith(b"HTTP/1.1 507"), answer[:300]
    assert seconds < 2.0


def test_a_json_job_body_is_at_most_the_request_limit(server):
    """Declared or not, a JSON job body past DYNAMICS_MAX_BODY_BYTES (8 MiB) is a 413 that says to send .npz; the
    server neither waits for nor decodes it."""
    answer, seconds = headers_only(server, "k1", "application/json", 16 * MiB)
    assert answer.startswith(b"HTTP/1.1 413") and seconds < 2.0, answer[:300]
    rows = np.round(np.random.default_rng(1).uniform(-1, 1, (90_000, 6)), 4).tolist()
    body = json.dumps({"robot": "puma560", "kind": "inverse_dynamics", "inputs": {"q": rows, "v": rows, "a": rows}})
    assert 12 * MiB < len(body) < 16 * MiB
    with client(server, "k1") as c:
        for content in (body.encode(), iter([body[i:i + MiB].encode() for i in range(0, len(body), MiB)])):
            before = rss_kib(server)
            reset_peak(server)
            t = time.monotonic()
            r = c.post("/v1/jobs", content=content, headers={"Content-Type": "application/json"})
            seconds = time.monotonic() - t
            detail = refused(r, 413, "body")["detail"]
            assert ".npz" in detail and "DYNAMICS_MAX_BODY_BYTES" in detail, detail
            assert seconds < 5.0  # (the whole body is sent by the client; the server decodes none of it)
            assert rss_kib(server, "VmHWM") - before < 48 * 1024, "a refused JSON body was decoded"
        assert c.get("/v1/jobs").json()["jobs"] == []


def test_an_npz_job_body_costs_about_the_arrays_it_holds(server):
    """64 MiB of puma560 states as .npz: the server's peak RSS grows by at most 1.5 times the body (the arrays
    held, once; the body itself goes to a file as it arrives). Before: the body in memory, joined, then the arrays
    read from it: about three times. The result is the library's."""
    states = 64 * MiB // (3 * 6 * 8)
    q, v, a = np.random.default_rng(2).uniform(-1, 1, (3, states, 6))
    content = npz_bytes(robot=np.array("puma560"), kind=np.array("inverse_dynamics"), q=q, v=v, a=a)
    with client(server, "k1") as c:
        c.post("/v1/robots/puma560/inverse-dynamics", json={"q": [0.0] * 6, "v": [0.0] * 6, "a": [0.0] * 6})
        before = rss_kib(server)
        reset_peak(server)
        r = c.post("/v1/jobs", content=content, headers={"Content-Type": NPZ})
        peak = rss_kib(server, "VmHWM") - before
        assert r.status_code == 202, r.text
        assert peak < 1.5 * len(content) / 1024, \
            f"peak RSS +{peak / 1024:.0f} MiB for a {len(content) / MiB:.0f} MiB body"
        job = r.json()
        end = time.monotonic() + 300
        while job["status"] in ("queued", "running") and time.monotonic() < end:
            time.sleep(0.2)
            job = c.get(job["status_url"]).json()
        assert job["status"] == "done", job
        with np.load(io.BytesIO(c.get(job["result_url"], headers={"Accept": NPZ}).content)) as z:
            tau = z["tau"]
        model = dynamics.load_urdf(str(ROBOTS / "puma560.urdf"))
        rows = np.r_[0:10, states - 10:states]
        assert tau.shape == (states, 6)
        assert np.array_equal(tau[rows], dynamics.inverse_dynamics(model, q[rows], v[rows], a[rows]))
        c.delete(job["status_url"])


# -- finding 2: members counted and named before any is read ---------------------------------------------------
def many_members(n: int, extra: dict | None = None) -> bytes:
    """An .npz of ``n`` empty float64 members (~220 bytes each), besides ``extra``."""
    one = io.BytesIO()
    np.save(one, np.zeros(0))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for name, value in (extra or {}).items():
            item = io.BytesIO()
            np.save(item, value)
            z.writestr(name + ".npy", item.getvalue())
        for i in range(n):
            z.writestr(f"m{i}.npy", one.getvalue())
    return buf.getvalue()


def test_an_npz_of_many_members_is_refused_before_any_is_read(server):
    body = many_members(36_000)
    results = {}

    def send(label, content):
        with client(server, "k1") as c:
            t = time.monotonic()
            r = c.post("/v1/robots/planar_2r/inverse-dynamics", content=content, headers={"Content-Type": NPZ})
            results[label] = (r, time.monotonic() - t)

    normal = npz_bytes(q=np.zeros((4, 2)), v=np.zeros((4, 2)), a=np.zeros((4, 2)))
    send("warm", normal)
    threads = [threading.Thread(target=send, args=(f"many{i}", body)) for i in range(2)]
    for t in threads:
        t.start()
    time.sleep(0.2)
    threads.append(threading.Thread(target=send, args=("normal", normal)))  # (both compute threads were held 14 s)
    threads[-1].start()
    for t in threads:
        t.join()
    for label in ("many0", "many1"):
        r, seconds = results[label]
        detail = refused(r, 422, "body")["detail"]
        assert "36000 members" in detail and "at most" in detail, detail
        assert seconds < 2.0, f"{seconds:.1f} s"  # 14.4 s before: each member was read, then refused
    r, seconds = results["normal"]
    assert r.status_code == 200 and seconds < 2.0, (r.status_code, seconds)


def test_a_job_body_of_many_members_is_refused_before_any_is_read(server):
    body = many_members(72_000, {"robot": np.array("puma560"), "kind": np.array("inverse_dynamics")})
    with client(server, "k1") as c:
        t = time.monotonic()
        r = c.post("/v1/jobs", content=body, headers={"Content-Type": NPZ})
        seconds = time.monotonic() - t
    refused(r, 422, "body")
    assert seconds < 2.0, f"{seconds:.1f} s"  # 14.3 s before


def test_member_names_are_checked_before_any_member_is_read(server):
    """A member the route does not take is named as an unknown field, not read: here its content is not even an
    .npy (before, it was read first and refused for that)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        one = io.BytesIO()
        np.save(one, np.zeros(2))
        z.writestr("q.npy", one.getvalue())
        z.writestr("qq.npy", b"not an npy member")
    with client(server, "k1") as c:
        r = c.post("/v1/robots/planar_2r/gravity-torques", content=buf.getvalue(), headers={"Content-Type": NPZ})
        detail = refused(r, 422, "qq")["detail"]
        assert "unknown field" in detail and "q" in detail.split("expected one of")[1], detail
        r = c.post("/v1/robots/planar_2r/gravity-torques", content=npz_bytes(q=np.zeros(2)),
                   headers={"Content-Type": NPZ})
        assert r.status_code == 200  # (the same member alone)


def test_an_end_record_that_understates_its_directory_is_refused_unread(server):
    """The member count an archive's end record states is checked with the size of the directory it states: an
    archive claiming 2 members over a directory of 36,000 is refused as quickly as one that says so."""
    body = bytearray(many_members(36_000))
    at = body.rfind(b"PK\x05\x06")
    struct.pack_into("<HH", body, at + 8, 2, 2)  # members on this disk, members in all
    with client(server, "k1") as c:
        t = time.monotonic()
        r = c.post("/v1/robots/planar_2r/inverse-dynamics", content=bytes(body), headers={"Content-Type": NPZ})
        seconds = time.monotonic() - t
    refused(r, 422, "body")
    assert seconds < 2.0


# -- finding 3: .npy headers parsed one at a time --------------------------------------------------------------
def test_npy_headers_are_parsed_one_at_a_time_on_every_compute_thread(tmp_path, monkeypatch):
    """Eight clients send .npz bodies to an app with four compute threads; numpy's header parser
    (ast.literal_eval) is watched: never two headers at once (on CPython 3.11 that is the 500 "AST constructor
    recursion depth mismatch"). The watcher sleeps inside the parser, so that without the lock two threads would
    meet there on nearly every request."""
    inside, overlaps, parsed = [0], [], [0]
    guard = threading.Lock()
    real = ast.literal_eval

    def watched(source):
        header = isinstance(source, str) and source.startswith("{'descr'")
        if header:
            with guard:
                inside[0] += 1
                parsed[0] += 1
                if inside[0] > 1:
                    overlaps.append(inside[0])
            time.sleep(0.002)  # (releases the GIL: another thread runs meanwhile)
        try:
            return real(source)
        finally:
            if header:
                with guard:
                    inside[0] -= 1

    monkeypatch.setattr(ast, "literal_eval", watched)
    q = np.random.default_rng(3).normal(size=(50, 2))
    body = npz_bytes(q=q, v=q, a=q)
    statuses = []
    with in_process_app(tmp_path / "store", compute_threads=4) as c:
        # (JSON answers: reading .npz answers here would parse headers in this process's client threads too)
        expected = c.post("/v1/robots/planar_2r/inverse-dynamics", content=body, headers={"Content-Type": NPZ}).json()

        def hammer():
            for _ in range(12):
                r = c.post("/v1/robots/planar_2r/inverse-dynamics", content=body, headers={"Content-Type": NPZ})
                statuses.append((r.status_code, r.json() == expected))

        threads = [threading.Thread(target=hammer) for _ in range(8)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert statuses == [(200, True)] * 96
    assert parsed[0] >= 3 * 96 and overlaps == [], f"{len(overlaps)} of {parsed[0]} headers parsed while another was"
