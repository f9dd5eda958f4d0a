"""Issues 11 and 49's reproductions, measured: `python -m benchmarks.hardening [--python PY] [--heavy]
[--section requests|bodies|all]`. Not in CI.

Starts `PY -m service` (default: this interpreter; pass another checkout's venv, or set PYTHONPATH to another
checkout, to measure it "before") with keys k1,k2 and the default limits, uploads a 128-joint chain with k1, then
sends each case and prints its status, wall time, the server's peak RSS during the case and its RSS 3 s after,
over the baseline.

Section "requests" (issue 11): hostile or oversize requests to the synchronous routes. The cases that took
gigabytes before the fix (16,000 and 12,000-state mass matrices, 200,000 int8 states, 99,999 samples) run only
with --heavy.

Section "bodies" (issue 49, findings 1 and 2): job bodies of puma560 inverse dynamics as JSON and as .npz (64 MiB;
255 MiB with --heavy), and .npz archives of many empty members: 36,000 sent twice at once to a synchronous route
while a normal request is sent, and 72,000 (288,000 with --heavy) as a job body.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import zipfile

import httpx
import numpy as np

from benchmarks.service import REPO, free_port, wait_for
from benchmarks.soak import rss_mb

sys.path.insert(0, str(REPO / "tests"))
from robots import chain_urdf  # noqa: E402

NPZ = "application/x-npz"
JSON_H = {"Content-Type": "application/json"}


def npz(compress=False, **arrays) -> bytes:
    buf = io.BytesIO()
    (np.savez_compressed if compress else np.savez)(buf, **arrays)
    return buf.getvalue()


def huge_header_npz() -> bytes:
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (10000000, 10000000), }"
    header = header + " " * (64 - (10 + len(header) + 1) % 64) + "\n"
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("q.npy", b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header.encode() + b"\0" * 16)
    return buf.getvalue()


def not_npy() -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("q.npy", b"not an npy member")
    return buf.getvalue()


def cases(chain: str, heavy: bool):
    x = {"Content-Type": NPZ}
    out = [
        ("q: number of 5,000 digits", "/v1/robots/planar-2r/gravity-torques",
         {"content": '{"q": [' + "9" * 5000 + ', 0]}', "headers": JSON_H}),
        ("locked: integer of 400 digits", "/v1/robots/planar-2r/gravity-torques",
         {"content": '{"q": [0.0], "locked": {"joint1": ' + "7" * 400 + "}}", "headers": JSON_H}),
        ("urdf: lone surrogate", "/v1/robots",
         {"content": '{"urdf": "<robot name=\\"x\\">\\ud800</robot>"}', "headers": JSON_H}),
        (".npz member not .npy", "/v1/robots/planar-2r/gravity-torques", {"content": not_npy(), "headers": x}),
        (".npz header (1e7, 1e7) over 16 B", "/v1/robots/planar-2r/gravity-torques",
         {"content": huge_header_npz(), "headers": x}),
        ("mass matrix 1,024 states JSON", f"/v1/robots/{chain}/mass-matrix",
         {"content": npz(q=np.zeros((1024, 128))), "headers": x}),
        ("floating_base: \"yes\"", "/v1/robots",
         {"content": json.dumps({"urdf": chain_urdf(2), "floating_base": "yes"}), "headers": JSON_H}),
        ("duration: \"1\"", "/v1/robots/planar-2r/simulate",
         {"content": '{"q0": [0, 0], "v0": [0, 0], "duration": "1"}', "headers": JSON_H}),
        ("Content-Type: ;;;;", "/v1/robots/planar-2r/gravity-torques",
         {"content": '{"q": [0, 0]}', "headers": {"Content-Type": ";;;;"}}),
        ("232-byte compressed .npz", "/v1/robots/planar-2r/gravity-torques",
         {"content": npz(True, q=np.array([0.3, -0.2])), "headers": x}),
        ("10,000-character id", "/v1/robots/" + "a" * 10_000 + "/gravity-torques",
         {"content": '{"q": [0, 0]}', "headers": JSON_H}),
        ("100k-link URDF", "/v1/robots",
         {"content": '<robot name="big">' + "".join(f'<link name="l{i}"/>' for i in range(100_000)) + "</robot>",
          "headers": {"Content-Type": "application/xml"}}),
        ("504: 20,000 states, 20 ms budget", f"/v1/robots/{chain}/inverse-dynamics",
         {"content": npz(True, **{k: np.zeros((20_000, 128)) for k in "qva"}),
          "headers": {**x, "Accept": NPZ, "X-Time-Budget": "0.02"}}),
        ("legal: mass matrix 1,000 states .npz (131 MB)", f"/v1/robots/{chain}/mass-matrix",
         {"content": npz(True, q=np.zeros((1000, 128))), "headers": {**x, "Accept": NPZ}}),
        ("legal: gravity 5,000 states JSON", f"/v1/robots/{chain}/gravity-torques",
         {"content": npz(True, q=np.zeros((5000, 128))), "headers": x}),
    ]
    if heavy:
        out += [
            ("mass matrix 16,000 states JSON", f"/v1/robots/{chain}/mass-matrix",
             {"content": npz(True, q=np.zeros((16_000, 128), np.float32)), "headers": x}),
            ("mass matrix 12,000 states .npz", f"/v1/robots/{chain}/mass-matrix",
             {"content": npz(True, q=np.zeros((12_000, 128), np.float32)), "headers": {**x, "Accept": NPZ}}),
            ("200k int8 states, 25 KB .npz", f"/v1/robots/{chain}/inverse-dynamics",
             {"content": npz(True, **{k: np.zeros((200_000, 128), np.int8) for k in "qva"}), "headers": x}),
            ("simulate 99,999 samples JSON", f"/v1/robots/{chain}/simulate",
             {"content": json.dumps({"q0": [0.0] * 128, "v0": [0.0] * 128, "duration": 9.9999,
                                     "sample_dt": 1e-4}), "headers": JSON_H}),
        ]
    return out


# -- issue 49: job bodies and many-member archives --------------------------------------------------------------
MiB = 1 << 20


def job_json(target_bytes: int) -> bytes:
    """A JSON job body of about ``target_bytes``: inverse dynamics of puma560 (q, v, a rows of 6 numbers of 4
    decimals, as a client writing them from a log would)."""
    rng = np.random.default_rng(49)
    sample = json.dumps(np.round(rng.uniform(-1, 1, (100, 6)), 4).tolist())
    states = int(target_bytes / (3 * len(sample) / 100))
    rows = {k: np.round(rng.uniform(-1, 1, (states, 6)), 4).tolist() for k in "qva"}
    return json.dumps({"robot": "puma560", "kind": "inverse_dynamics", "inputs": rows}).encode()


def job_npz(target_bytes: int) -> bytes:
    """An .npz job body of about ``target_bytes``: the same job, float64 states (3 x 6 x 8 bytes each)."""
    states = target_bytes // (3 * 6 * 8)
    rng = np.random.default_rng(49)
    return npz(robot=np.array("puma560"), kind=np.array("inverse_dynamics"),
               **{k: rng.uniform(-1, 1, (states, 6)) for k in "qva"})


def many_members(n: int, extra: dict | None = None) -> bytes:
    """An .npz of ``n`` empty float64 members (about 220 bytes each) besides the arrays of ``extra``."""
    one = io.BytesIO()
    np.save(one, np.zeros(0))
    member = one.getvalue()
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for name, value in (extra or {}).items():
            item = io.BytesIO()
            np.save(item, value)
            z.writestr(name + ".npy", item.getvalue())
        for i in range(n):
            z.writestr(f"m{i}.npy", member)
    return buf.getvalue()


def body_cases(heavy: bool):
    x = {"Content-Type": NPZ}
    sizes = (64, 255) if heavy else (64,)
    out = []
    for mib in sizes:
        out.append((f"job body JSON {mib} MiB (puma560 inverse dynamics)", "/v1/jobs",
                    {"content": job_json(mib * MiB), "headers": JSON_H}))
        out.append((f"job body .npz {mib} MiB (puma560 inverse dynamics)", "/v1/jobs",
                    {"content": job_npz(mib * MiB), "headers": x}))
    robot = {"robot": np.array("puma560"), "kind": np.array("inverse_dynamics")}
    for n in (72_000, 288_000) if heavy else (72_000,):
        out.append((f"job body .npz of {n:,} empty members", "/v1/jobs",
                    {"content": many_members(n, robot), "headers": x}))
    return out


def members_at_once(url: str, key: str, n: int = 36_000) -> list[tuple[str, object, float]]:
    """Two .npz bodies of ``n`` empty members sent at once to inverse dynamics (the server's two compute threads),
    and a normal one-state request sent 0.5 s later: (label, status, seconds) of each."""
    body = many_members(n)
    results: list = []

    def send(label, kw):
        t0 = time.monotonic()
        try:
            with httpx.Client(base_url=url, timeout=300, headers={"Authorization": f"Bearer {key}"}) as c:
                status = c.post("/v1/robots/planar_2r/inverse-dynamics", **kw).status_code
        except httpx.HTTPError as e:
            status = type(e).__name__
        results.append((label, status, time.monotonic() - t0))

    many = {"content": body, "headers": {"Content-Type": NPZ}}
    normal = {"content": npz(q=np.zeros((4, 2)), v=np.zeros((4, 2)), a=np.zeros((4, 2))),
              "headers": {"Content-Type": NPZ}}
    threads = [threading.Thread(target=send, args=(f".npz of {n:,} empty members ({len(body) / 1e6:.0f} MB), "
                                                   f"#{i + 1} of 2 at once", many)) for i in range(2)]
    for t in threads:
        t.start()
    time.sleep(0.5)
    threads.append(threading.Thread(target=send, args=("a normal request sent meanwhile", normal)))
    threads[-1].start()
    for t in threads:
        t.join()
    return results


def measure(c: httpx.Client, pid: int, path: str, kw: dict) -> tuple[int, float, float, float]:
    base = rss_mb(pid)
    peak = [base]
    done = threading.Event()

    def sample():
        while not done.is_set():
            peak[0] = max(peak[0], rss_mb(pid))
            time.sleep(0.05)

    t = threading.Thread(target=sample)
    t.start()
    t0 = time.monotonic()
    try:
        status = c.post(path, **kw).status_code
    except httpx.HTTPError as e:
        status = type(e).__name__
    seconds = time.monotonic() - t0
    done.set()
    t.join()
    time.sleep(3)
    return status, seconds, peak[0] - base, rss_mb(pid) - base


def slow_clients(url: str, port: int, n: int = 200, wait: float = 35.0) -> int:
    """Connections with half-sent headers or bodies still open after ``wait`` seconds."""
    socks = []
    for i in range(n):
        s = socket.create_connection(("127.0.0.1", port))
        s.sendall(b"GET /v1/health HTTP/1.1\r\nHost: x\r\nX-Slow: " if i % 2 else
                  b"POST /v1/robots/planar-2r/gravity-torques HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer k1\r\n"
                  b"Content-Type: application/json\r\nContent-Length: 100\r\n\r\n{")
        s.setblocking(False)
        socks.append(s)
    time.sleep(wait)
    open_ = 0
    for s in socks:
        try:
            while s.recv(65536):
                pass
        except BlockingIOError:
            open_ += 1  # no EOF: still open
        except OSError:
            pass
        s.close()
    return open_


def health_under_load(url: str, chain: str, key: str) -> float:
    stop = threading.Event()
    body = json.dumps({"q": [0.1] * 128})

    def hammer():
        with httpx.Client(base_url=url, headers={"Authorization": f"Bearer {key}"}, timeout=60) as c:
            while not stop.is_set():
                c.post(f"/v1/robots/{chain}/mass-matrix", content=body, headers=JSON_H)

    threads = [threading.Thread(target=hammer) for _ in range(4)]
    for t in threads:
        t.start()
    time.sleep(1.0)
    lat = []
    with httpx.Client(base_url=url) as c:
        for _ in range(100):
            t0 = time.perf_counter()
            c.get("/v1/health")
            lat.append(time.perf_counter() - t0)
    stop.set()
    for t in threads:
        t.join()
    return float(np.median(lat))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--python", default=sys.executable)
    p.add_argument("--heavy", action="store_true")
    p.add_argument("--slow", action="store_true", help="also 200 half-sent requests held for 35 s")
    p.add_argument("--section", choices=("requests", "bodies", "all"), default="all")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        port = free_port()
        # (the bodies section simulates nothing: no simulation worker, whose warm-up takes minutes on a cold cache)
        env = {**os.environ, "DYNAMICS_API_KEYS": "k1,k2", "DYNAMICS_ROBOTS_DIR": str(REPO / "robots"),
               "DYNAMICS_SIM_WORKERS": "0" if args.section == "bodies" else "1", "DYNAMICS_COMPUTE_THREADS": "2"}
        proc = subprocess.Popen([args.python, "-m", "service", "--port", str(port), "--store", f"{tmp}/store",
                                 "--log-level", "warning"], env=env, cwd=tmp, start_new_session=True)
        url = f"http://127.0.0.1:{port}"
        try:
            if not wait_for(url + "/v1/ready", time.monotonic() + 600):
                raise SystemExit("no server")
            with httpx.Client(base_url=url, timeout=120, headers={"Authorization": "Bearer k1"}) as c:
                chain = c.post("/v1/robots", content=chain_urdf(128),
                               headers={"Content-Type": "application/xml"}).json()["id"]
                c.post(f"/v1/robots/{chain}/mass-matrix", json={"q": [0.0] * 128})
                print(f"server RSS at start {rss_mb(proc.pid):.0f} MB\n")
                print("| case | status | seconds | peak RSS over baseline, MB | RSS 3 s after, MB |\n|---|---|---|---|---|")
                chosen = (cases(chain, args.heavy) if args.section != "bodies" else []) + \
                    (body_cases(args.heavy) if args.section != "requests" else [])
                for label, path, kw in chosen:
                    status, seconds, peak, after = measure(c, proc.pid, path, kw)
                    print(f"| {label} | {status} | {seconds:.2f} | {peak:+.0f} | {after:+.0f} |", flush=True)
                    if path == "/v1/jobs" and status == 202:  # (the next job body is not refused for the limit)
                        for job in c.get("/v1/jobs").json()["jobs"]:
                            c.delete(f"/v1/jobs/{job['id']}")
                if args.section != "requests":
                    for label, status, seconds in members_at_once(url, "k1"):
                        print(f"| {label} | {status} | {seconds:.2f} | | |", flush=True)
                if args.section == "bodies":
                    return 0
                with httpx.Client(base_url=url, headers={"Authorization": "Bearer k2"}) as k2:
                    print(f"| key k2 reads k1's robot | {k2.get(f'/v1/robots/{chain}').status_code} | | | |")
                    print(f"| key k2 computes with k1's robot | "
                          f"{k2.post(f'/v1/robots/{chain}/gravity-torques', json={'q': [0.0] * 128}).status_code}"
                          f" | | | |")
                print(f"| OPTIONS /v1/robots Allow | {c.options('/v1/robots').headers.get('allow')!r} | | | |")
                print(f"\n/v1/health median under 4 clients of 128-joint mass matrices: "
                      f"{health_under_load(url, chain, 'k1') * 1e3:.1f} ms")
                if args.slow:
                    print(f"half-sent requests still open after 35 s: {slow_clients(url, port)} of 200")
        finally:
            proc.terminate()
            proc.wait(15)
    return 0


if __name__ == "__main__":
    sys.exit(main())
