"""Issue 11 replayed against a real server process: each hostile or oversize request gets a clear 4xx naming
the field (never a 5xx), within the time budget + 1 s, and the server's memory returns near its baseline.

The server here has a small time budget and small answer limits, so that the cases stay fast; what they prove
(a refusal before the work, memory released after a 504) does not depend on the numbers.
"""

from __future__ import annotations

import io
import json
import socket
import struct
import time
import zipfile

import httpx
import numpy as np
import pytest

from robots import chain_urdf
from service_fixtures import Server

JSON_H = {"Content-Type": "application/json"}
NPZ = "application/x-npz"
BUDGET = 3.0


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    root = tmp_path_factory.mktemp("hardening")
    s = Server(root / "store", env={"DYNAMICS_TIME_BUDGET": str(BUDGET), "DYNAMICS_API_KEYS": "k1,k2",
                                    "DYNAMICS_READ_TIMEOUT": "2"}).start()
    yield s
    s.stop()


def client(server, key="k1"):
    return httpx.Client(base_url=server.url, timeout=60, headers={"Authorization": f"Bearer {key}"})


@pytest.fixture(scope="module")
def http(server):
    with client(server) as c:
        yield c


@pytest.fixture(scope="module")
def chain(http):
    """A 128-joint chain, uploaded with key k1."""
    r = http.post("/v1/robots?name=chain128", content=chain_urdf(128), headers={"Content-Type": "application/xml"})
    assert r.status_code in (200, 201), r.text
    return r.json()["id"]


def npz_bytes(compress=False, **arrays) -> bytes:
    buf = io.BytesIO()
    (np.savez_compressed if compress else np.savez)(buf, **arrays)
    return buf.getvalue()


def timed(call):
    t = time.monotonic()
    r = call()
    return r, time.monotonic() - t


def refused(r, status, field=None):
    assert r.status_code == status, (r.status_code, r.text[:500])
    body = r.json()
    assert set(body) >= {"detail", "code", "field"} and len(r.text) < 2000
    if field is not None:
        assert body["field"] == field and body["detail"].startswith(field), body
    return body


# -- section 1: the five 5xx -----------------------------------------------------------------------------------
def test_number_of_5000_digits_names_the_field(http):
    q = "[" + "9" * 5000 + ", 0]"
    r = http.post("/v1/robots/planar-2r/gravity-torques", content='{"q": ' + q + "}", headers=JSON_H)
    refused(r, 422, "q")


def test_locked_integer_of_400_digits_names_the_joint(http):
    body = '{"q": [0.0], "locked": {"joint1": ' + "7" * 400 + "}}"
    r = http.post("/v1/robots/planar-2r/gravity-torques", content=body, headers=JSON_H)
    assert refused(r, 422)["field"].startswith("locked")


def test_lone_surrogate_in_json_urdf(http):
    r = http.post("/v1/robots", content='{"urdf": "<robot name=\\"x\\">\\ud800</robot>"}', headers=JSON_H)
    refused(r, 422, "urdf")


def test_npz_member_not_npy(http):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("q.npy", b"this is not an npy file at all")
    r = http.post("/v1/robots/planar-2r/gravity-torques", content=buf.getvalue(), headers={"Content-Type": NPZ})
    refused(r, 422, "q")


def test_npz_header_claiming_huge_shape(http):
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (10000000, 10000000), }"
    header = header + " " * (64 - (10 + len(header) + 1) % 64) + "\n"
    member = b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode() + b"\0" * 16
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("q.npy", member)
    r = http.post("/v1/robots/planar-2r/gravity-torques", content=buf.getvalue(), headers={"Content-Type": NPZ})
    refused(r, 422, "q")


def test_answers_carry_a_request_id(http):
    r = http.get("/v1/robots", headers={"X-Request-ID": "abc-123"})
    assert r.status_code == 200 and r.headers["x-request-id"] == "abc-123"
    r = http.get("/v1/robots/nope")
    assert r.status_code == 404 and len(r.headers["x-request-id"]) == 16


def test_client_disconnect_mid_body_is_not_logged(server, http):
    before = server.log.read_text() if server.log.exists() else ""
    for _ in range(5):
        with socket.create_connection(("127.0.0.1", server.port)) as s:
            s.sendall(b"POST /v1/robots/planar-2r/gravity-torques HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer k1\r\n"
                      b"Content-Type: application/json\r\nContent-Length: 100000\r\n\r\n{\"q\": [")
            time.sleep(0.05)
    time.sleep(0.5)
    assert http.get("/v1/health").status_code == 200
    after = server.log.read_text()[len(before):]
    assert "Traceback" not in after and "ClientDisconnect" not in after, after[:2000]


# -- section 2: memory and time bounded ------------------------------------------------------------------------
def rss_mb(server) -> float:
    return server.rss_kib() / 1024


def settle_rss(server, baseline, tol_mb=200.0, wait=5.0) -> float:
    """The server's RSS, waited for (a freed answer is unmapped once sent) until within tol of baseline."""
    end = time.monotonic() + wait
    while rss_mb(server) > baseline + tol_mb and time.monotonic() < end:
        time.sleep(0.2)
    return rss_mb(server)


@pytest.mark.parametrize("states, accept", [(16_000, None), (2_048, None), (12_000, NPZ)])
def test_mass_matrix_answers_too_large_are_refused_before_computing(server, http, chain, states, accept):
    base = rss_mb(server)
    q = np.zeros((states, 128), dtype=np.float32)
    headers = {"Content-Type": NPZ, **({"Accept": accept} if accept else {})}
    r, seconds = timed(lambda: http.post(f"/v1/robots/{chain}/mass-matrix", content=npz_bytes(True, q=q),
                                         headers=headers))
    body = refused(r, 413, "answer")
    assert ("DYNAMICS_MAX_ANSWER_BYTES" if accept else "DYNAMICS_MAX_JSON_ANSWER_BYTES") in body["detail"]
    assert seconds < BUDGET + 1 and settle_rss(server, base) < base + 200


def test_compressed_int8_states_count_unpacked_size(server, http, chain):
    base = rss_mb(server)
    q = np.zeros((200_000, 128), dtype=np.int8)
    content = npz_bytes(True, q=q, v=q, a=q)
    assert len(content) < 200_000
    r, seconds = timed(lambda: http.post(f"/v1/robots/{chain}/inverse-dynamics", content=content,
                                         headers={"Content-Type": NPZ}))
    refused(r, 413, "body")
    assert seconds < BUDGET + 1 and settle_rss(server, base) < base + 200


def test_memory_released_after_a_504(server, http, chain):
    q = np.zeros((20_000, 128))
    content = npz_bytes(True, q=q, v=q, a=q)
    http.post(f"/v1/robots/{chain}/inverse-dynamics", content=npz_bytes(q=q[:2], v=q[:2], a=q[:2]),
              headers={"Content-Type": NPZ})
    base = rss_mb(server)
    r, seconds = timed(lambda: http.post(f"/v1/robots/{chain}/inverse-dynamics", content=content,
                                         headers={"Content-Type": NPZ, "Accept": NPZ, "X-Time-Budget": "0.02"}))
    assert r.status_code == 504, r.text[:300]
    assert seconds < BUDGET + 1 and settle_rss(server, base) < base + 200


def test_simulate_99999_samples_as_json_is_refused(http, chain):
    payload = {"q0": [0.0] * 128, "v0": [0.0] * 128, "duration": 9.9999, "sample_dt": 1e-4}
    r, seconds = timed(lambda: http.post(f"/v1/robots/{chain}/simulate", json=payload))
    refused(r, 413, "answer")
    assert seconds < BUDGET + 1


def test_large_json_answer_is_fast_and_exact(http, chain):
    q = np.random.default_rng(0).normal(size=(5_000, 128))
    r = http.post(f"/v1/robots/{chain}/gravity-torques", content=npz_bytes(q=q), headers={"Content-Type": NPZ})
    assert r.status_code == 200
    tau = np.array(r.json()["tau"])
    r = http.post(f"/v1/robots/{chain}/gravity-torques", content=npz_bytes(q=q),
                  headers={"Content-Type": NPZ, "Accept": NPZ})
    with np.load(io.BytesIO(r.content)) as z:
        assert np.array_equal(tau, z["tau"])  # orjson writes the shortest round-trip repr


def test_small_requests_do_not_stall_the_event_loop(server, chain):
    """Four clients sending one-state 128-joint mass-matrix requests (1.8 KB bodies); /v1/health stays fast."""
    import threading
    stop = threading.Event()
    body = json.dumps({"q": [0.1] * 128})

    def hammer():
        with client(server) as c:
            while not stop.is_set():
                c.post(f"/v1/robots/{chain}/mass-matrix", content=body, headers=JSON_H)

    threads = [threading.Thread(target=hammer) for _ in range(4)]
    for t in threads:
        t.start()
    try:
        time.sleep(0.5)
        with httpx.Client(base_url=server.url) as c:
            latencies = sorted(timed(lambda: c.get("/v1/health"))[1] for _ in range(40))
    finally:
        stop.set()
        for t in threads:
            t.join()
    assert latencies[len(latencies) // 2] < 0.05, latencies  # 224 ms before (issue 11); ~1 ms idle


def test_urdf_with_100k_links_refused_while_parsing(http):
    links = "".join(f'<link name="l{i}"/>' for i in range(100_000))
    r, seconds = timed(lambda: http.post("/v1/robots", content=f'<robot name="big">{links}</robot>',
                                         headers={"Content-Type": "application/xml"}))
    refused(r, 413, "urdf")
    assert seconds < BUDGET + 1


def test_urdf_name_is_capped(http):
    r = http.post("/v1/robots", content=chain_urdf(2, name="n" * 200), headers={"Content-Type": "application/xml"})
    assert r.status_code == 201 and r.json()["name"] == "n" * 128
    r = http.post("/v1/robots", content=chain_urdf(2, name="n" * 4_000_000),
                  headers={"Content-Type": "application/xml"})
    refused(r, 422, "urdf")  # the library refuses names past 256 characters, with a short message


def test_half_sent_headers_and_bodies_are_closed(server):
    socks = []
    for i in range(50):
        s = socket.create_connection(("127.0.0.1", server.port))
        if i % 2:
            s.sendall(b"GET /v1/health HTTP/1.1\r\nHost: x\r\nX-Slow: ")
        else:
            s.sendall(b"POST /v1/robots/planar-2r/gravity-torques HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer k1\r\n"
                      b"Content-Type: application/json\r\nContent-Length: 100\r\n\r\n{\"q\"")
        s.settimeout(10)
        socks.append(s)
    t = time.monotonic()
    for s in socks:  # the server closes each (an answer 408 for the bodies, nothing for the headers), then EOF
        data = b""
        while True:
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
        assert data == b"" or data.startswith(b"HTTP/1.1 408"), data[:200]
        s.close()
    assert time.monotonic() - t < 2.0 + 3.0  # DYNAMICS_READ_TIMEOUT = 2 s here


def test_listing_reads_no_urdf(server, http):
    """Uploads then listings: the listing's cost does not grow with the size of the stored URDFs."""
    for i in range(5):
        pad = "<!-- " + "x" * 1_000_000 + " -->"
        r = http.post(f"/v1/robots?name=padded{i}", content=chain_urdf(3).replace("</robot>", pad + "</robot>"),
                      headers={"Content-Type": "application/xml"})
        assert r.status_code in (200, 201), r.text
    http.get("/v1/robots")
    seconds = min(timed(lambda: http.get("/v1/robots"))[1] for _ in range(5))
    assert seconds < 0.2


# -- section 3 and issue 13 item 8: keys, isolation, names ------------------------------------------------------
def test_robots_belong_to_their_key(server, http, chain):
    with client(server, "k2") as other:
        assert chain not in [r["id"] for r in other.get("/v1/robots").json()["robots"]]
        assert "planar_2r" in [r["id"] for r in other.get("/v1/robots").json()["robots"]]
        refused(other.get(f"/v1/robots/{chain}"), 404, "robot")
        refused(other.post(f"/v1/robots/{chain}/gravity-torques", json={"q": [0.0] * 128}), 404, "robot")
        refused(other.post(f"/v1/robots/{chain}/simulate", json={"q0": [0.0] * 128, "v0": [0.0] * 128,
                                                                 "duration": 0.01}), 404, "robot")
        refused(other.delete(f"/v1/robots/{chain}"), 404, "robot")
        refused(other.delete("/v1/robots/planar-2r"), 403, "robot")
        assert other.post("/v1/robots/planar-2r/gravity-torques", json={"q": [0.0, 0.0]}).status_code == 200
        # the same URDF from two keys: two robots, each key sees its own
        mine = other.post("/v1/robots?name=chain128", content=chain_urdf(128),
                          headers={"Content-Type": "application/xml"})
        assert mine.status_code == 201 and mine.json()["id"] != chain
        assert other.get("/v1/robots/chain128").json()["id"] == mine.json()["id"]
        assert other.delete(f"/v1/robots/{mine.json()['id']}").status_code == 204
    assert http.get(f"/v1/robots/{chain}").status_code == 200


def test_names_address_robots_and_reuploads_answer_200(http, chain):
    assert http.get("/v1/robots/chain128").json()["id"] == chain
    r = http.post("/v1/robots?name=chain128", content=chain_urdf(128), headers={"Content-Type": "application/xml"})
    assert r.status_code == 200 and r.json()["id"] == chain
    r = http.post("/v1/robots?name=chain128", content=chain_urdf(5), headers={"Content-Type": "application/xml"})
    refused(r, 409, "name")
    r = http.post("/v1/robots/chain128/gravity-torques", json={"q": [0.0] * 128})
    assert r.status_code == 200 and len(r.json()["tau"]) == 128


def test_echoed_ids_are_capped(http):
    r = http.get("/v1/robots/" + "a" * 10_000)
    assert refused(r, 404, "robot") and len(r.text) < 400


# -- section 4: schema and protocol ----------------------------------------------------------------------------
@pytest.mark.parametrize("payload, field", [
    ({"urdf": "<robot name='a'><link name='b'/></robot>", "floating_base": "yes"}, "floating_base"),
    ({"urdf": "<robot name='a'><link name='b'/></robot>", "floating_base": 1}, "floating_base"),
])
def test_upload_types_are_strict(http, payload, field):
    refused(http.post("/v1/robots", json=payload), 422, field)


@pytest.mark.parametrize("duration", ["1", True, 1e400])
def test_simulate_duration_is_a_number(http, duration):
    body = '{"q0": [0, 0], "v0": [0, 0], "duration": ' + json.dumps(duration).replace("Infinity", "1e400") + "}"
    refused(http.post("/v1/robots/planar-2r/simulate", content=body, headers=JSON_H), 422, "duration")


def test_content_type_without_a_media_type_is_refused(http):
    for path, body in (("/v1/robots/planar-2r/gravity-torques", '{"q": [0, 0]}'), ("/v1/robots", '{"urdf": "x"}')):
        refused(http.post(path, content=body, headers={"Content-Type": ";;;;"}), 415, "Content-Type")


def test_options_lists_the_methods(http):
    r = http.options("/v1/robots")
    assert r.status_code == 204 and set(r.headers["allow"].split(", ")) == {"GET", "HEAD", "POST", "OPTIONS"}
    r = http.options("/v1/robots/planar-2r")
    assert set(r.headers["allow"].split(", ")) == {"GET", "HEAD", "DELETE", "OPTIONS"}
    assert http.options("/v1/nothing").status_code == 404


def test_small_compressed_npz_is_accepted(http):
    content = npz_bytes(True, q=np.array([0.3, -0.2]))
    assert len(content) < 400
    r = http.post("/v1/robots/planar-2r/gravity-torques", content=content, headers={"Content-Type": NPZ})
    assert r.status_code == 200 and len(r.json()["tau"]) == 2


def test_extreme_urdf_values(http):
    """An axis of 1e300 1e300 1e300 is the unit axis (1, 1, 1)/sqrt(3), not an overflow; NaN limits are refused."""
    q = {"q": [0.4, -0.3]}
    taus = []
    for axis in ("1 1 1", "1e300 1e300 1e300"):
        urdf = chain_urdf(2, name=f"axis{len(axis)}", axis=axis)
        rid = http.post("/v1/robots", content=urdf, headers={"Content-Type": "application/xml"}).json()["id"]
        taus.append(http.post(f"/v1/robots/{rid}/gravity-torques", json=q).json()["tau"])
    assert np.allclose(taus[0], taus[1], rtol=1e-14, atol=1e-14) and np.abs(taus[0]).max() > 0.1
    urdf = chain_urdf(2).replace('lower="-3.14"', 'lower="nan"')
    refused(http.post("/v1/robots", content=urdf, headers={"Content-Type": "application/xml"}), 422, "urdf")


def test_a_body_trickled_one_byte_at_a_time_is_timed_out(server):
    """Issue 25 A5: one byte every 5 s was never timed out (only a gap over DYNAMICS_READ_TIMEOUT was). Here one
    byte every 0.5 s (the read timeout is 2 s): the whole body is bounded, so a 408 comes after about 2 s."""
    with socket.create_connection(("127.0.0.1", server.port), timeout=30) as sock:
        sock.sendall(b"POST /v1/robots/planar_2r/mass-matrix HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer k1\r\n"
                     b"Content-Type: application/json\r\nContent-Length: 1000\r\n\r\n")
        answer = b""
        for _ in range(40):  # at most 20 s of trickling
            try:
                sock.sendall(b" ")
            except OSError:  # the server answered and closed
                break
            sock.settimeout(0.5)
            try:
                chunk = sock.recv(4096)
            except socket.timeout:
                continue
            if not chunk:
                break
            answer += chunk
            if b"\r\n\r\n" in answer:
                break
    assert answer.startswith(b"HTTP/1.1 408"), answer[:300]
    assert b"DYNAMICS_READ_TIMEOUT" in answer or b"\r\n\r\n" in answer


# -- issue 49, findings 4 to 6: HEAD, the headers of every answer, names ---------------------------------------
@pytest.mark.parametrize("path", ["/v1/health", "/v1/robots", "/v1/robots/planar_2r", "/inspect", "/inspect/planar_2r",
                                  "/inspect/static/inspector.js", "/openapi.json"])
def test_head_is_get_without_the_body(http, path):
    """OPTIONS advertises HEAD wherever GET is (Allow: GET, HEAD, OPTIONS); HEAD answered 405 on every route."""
    get, head = http.get(path), http.head(path)
    assert get.status_code == 200 and head.status_code == 200, (path, head.status_code)
    assert head.content == b"" and head.headers["content-type"] == get.headers["content-type"]
    assert head.headers["content-length"] == str(len(get.content))
    assert "HEAD" in http.options(path).headers["allow"].split(", ")


def test_head_where_there_is_no_get(http):
    r = http.head("/v1/robots/planar_2r/inverse-dynamics")
    assert r.status_code == 405 and r.content == b"" and "HEAD" not in http.options(
        "/v1/robots/planar_2r/inverse-dynamics").headers["allow"]


def test_the_inspector_cannot_be_framed_and_runs_only_its_own_scripts(http):
    """/inspect, where users type their API key: a Content-Security-Policy (scripts from this server only, never
    framed) and X-Frame-Options; the page holds no inline script the policy would block."""
    import re
    for path in ("/inspect", "/inspect/planar_2r"):
        r = http.get(path)
        policy = dict(p.strip().split(" ", 1) for p in r.headers["content-security-policy"].split(";"))
        assert policy["frame-ancestors"] == "'none'" and r.headers["x-frame-options"] == "DENY"
        assert policy["script-src"] == "'self'" and policy["object-src"] == "'none'"
        page = r.text
        assert not re.search(r"<script(?![^>]*\bsrc=)[^>]*>", page), "an inline script"
        assert not re.search(r"\son[a-z]+\s*=", page), "an inline event handler"
    docs = http.get("/docs")  # (Swagger UI has a field for the key too: not framed either)
    assert "frame-ancestors 'none'" in docs.headers["content-security-policy"]


def test_every_answer_says_nosniff(server, http):
    answers = [http.get("/v1/health"), http.get("/v1/robots"), http.get("/v1/robots/nope"), http.get("/inspect"),
               http.get("/inspect/static/inspector.js"), http.options("/v1/robots"), http.delete("/v1/health"),
               http.post("/v1/robots/planar_2r/gravity-torques", json={"q": [0.0]}), http.head("/v1/health")]
    with httpx.Client(base_url=server.url) as anonymous:
        answers.append(anonymous.get("/v1/robots"))  # 401, from the key check
    assert [r.status_code for r in answers] == [200, 200, 404, 200, 200, 204, 405, 422, 200, 401]
    for r in answers:
        assert r.headers.get("x-content-type-options") == "nosniff", (r.request.url, r.status_code)


@pytest.mark.parametrize("name", ["", " ", "a/b", "..", "../chain128", "x\\y", "admin\u202egnp.exe", "pla\u200bnar",
                                  "tab\there", " padded"])
def test_names_that_are_empty_or_spoof_listings_are_refused(http, name):
    """An empty ?name= fell back to the URDF's name yet counted as given (a 409 about another robot); names with
    '/', '..' or bidirectional overrides were stored and listed. All are a 422 naming name, in both forms of upload."""
    r = http.post("/v1/robots", params={"name": name}, content=chain_urdf(2, name="fresh"),
                  headers={"Content-Type": "application/xml"})
    refused(r, 422, "name")
    r = http.post("/v1/robots", json={"urdf": chain_urdf(2, name="fresh"), "name": name})
    refused(r, 422, "name")
    assert "fresh" not in [x["name"] for x in http.get("/v1/robots").json()["robots"]]


def test_a_urdf_s_own_name_is_checked_too_and_ordinary_names_pass(http):
    r = http.post("/v1/robots", content=chain_urdf(2, name="a/b"), headers={"Content-Type": "application/xml"})
    assert "?name=" in refused(r, 422, "name")["detail"]
    r = http.post("/v1/robots?name=my arm (v2.1)", content=chain_urdf(2, name="a/b"),
                  headers={"Content-Type": "application/xml"})
    assert r.status_code == 201 and r.json()["name"] == "my arm (v2.1)", r.text
    assert http.delete(f"/v1/robots/{r.json()['id']}").status_code == 204
