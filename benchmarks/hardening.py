"""Issue 11's reproductions, measured: `python -m benchmarks.hardening [--python PY] [--heavy]`. Not in CI.

Starts `PY -m service` (default: this interpreter; pass another checkout's venv to measure it "before") with
keys k1,k2 and the default limits, uploads a 128-joint chain with k1, then sends each case and prints its
status, wall time, the server's peak RSS during the case and its RSS 3 s after, over the baseline. The cases
that took gigabytes before the fix (16,000 and 12,000-state mass matrices, 200,000 int8 states, 99,999
samples) run only with --heavy.
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
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        port = free_port()
        env = {**os.environ, "DYNAMICS_API_KEYS": "k1,k2", "DYNAMICS_ROBOTS_DIR": str(REPO / "robots"),
               "DYNAMICS_SIM_WORKERS": "1", "DYNAMICS_COMPUTE_THREADS": "2"}
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
                for label, path, kw in cases(chain, args.heavy):
                    status, seconds, peak, after = measure(c, proc.pid, path, kw)
                    print(f"| {label} | {status} | {seconds:.2f} | {peak:+.0f} | {after:+.0f} |", flush=True)
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
