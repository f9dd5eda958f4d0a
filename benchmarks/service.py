"""Service benchmark (issue 4, section 6): `python -m benchmarks.service [--robot puma560] [--n 2000]`.

Starts the service (`python -m service`) on a free loopback port with an empty temporary store, then, in one run
and through one keep-alive HTTP connection (httpx), single-state requests interleaved with trivial ones so
that the load of a shared machine falls on both alike:

* single-state inverse dynamics: requests per second and p50 / p99 latency, next to the trivial endpoint
  (GET /v1/health) of the same server and the bare library call in this process;
* a 10,000-state batch of inverse dynamics end to end (client-side encoding, HTTP, server, decoding of the
  answer into a numpy array), in JSON and in `.npz`, as ratios to the library call on the same batch and to
  the trivial endpoint.

Targets (issue 4): single-state p50 at most 1.5x the trivial endpoint's; the 10,000-state `.npz` batch at most
2x the library time + 10 ms. Batch timings are the best of --repeat runs (the machine is shared: the minimum
is the least disturbed run); latencies are percentiles over --n sequential requests after a warm-up. The
table is printed as markdown and written to benchmarks/out/service.md (git-ignored).
"""

from __future__ import annotations

import argparse
import io
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx
import numpy as np

REPO = Path(__file__).resolve().parent.parent
NPZ = "application/x-npz"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_server(store: Path) -> tuple[subprocess.Popen, str]:
    port = free_port()
    env = {**os.environ, "DYNAMICS_SIM_WORKERS": "0"}
    if "DYNAMICS_ROBOTS_DIR" not in env and (REPO / "robots").is_dir():
        env["DYNAMICS_ROBOTS_DIR"] = str(REPO / "robots")
    proc = subprocess.Popen([sys.executable, "-m", "service", "--host", "127.0.0.1", "--port", str(port),
                             "--store", str(store), "--log-level", "warning"], env=env, start_new_session=True)
    url = f"http://127.0.0.1:{port}"
    end = time.monotonic() + 120
    while time.monotonic() < end:
        try:
            if httpx.get(url + "/v1/health", timeout=1).status_code == 200:
                return proc, url
        except httpx.TransportError:
            time.sleep(0.1)
    proc.kill()
    raise SystemExit("the service did not start")


def latencies(fn, n: int) -> np.ndarray:
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        fn()
        out[i] = time.perf_counter() - t0
    return out


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def npz_bytes(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robot", default="puma560", help="bundled robot (default puma560)")
    p.add_argument("--n", type=int, default=2000, help="single-state requests per endpoint")
    p.add_argument("--batch", type=int, default=10_000)
    p.add_argument("--repeat", type=int, default=7)
    args = p.parse_args(argv)

    import dynamics

    model = dynamics.load_urdf(str(REPO / "robots" / f"{args.robot.replace('-', '_')}.urdf"))
    rid = args.robot.replace("_", "-")
    rng = np.random.default_rng(0)
    q1, v1, a1 = rng.uniform(-1, 1, (3, model.nq))
    qb, vb, ab = rng.uniform(-1, 1, (3, args.batch, model.nq))

    with tempfile.TemporaryDirectory() as tmp:
        proc, url = start_server(Path(tmp) / "store")
        try:
            with httpx.Client(base_url=url, timeout=120) as http:
                single_body = json.dumps({"q": q1.tolist(), "v": v1.tolist(), "a": a1.tolist()}).encode()
                headers = {"Content-Type": "application/json"}
                path = f"/v1/robots/{rid}/inverse-dynamics"

                def trivial():
                    r = http.get("/v1/health")
                    assert r.status_code == 200

                def single():
                    r = http.post(path, content=single_body, headers=headers)
                    assert r.status_code == 200, r.text
                    return np.asarray(r.json()["tau"])

                assert np.array_equal(single(), dynamics.inverse_dynamics(model, q1, v1, a1))

                def batch_json():
                    body = json.dumps({"q": qb.tolist(), "v": vb.tolist(), "a": ab.tolist()}).encode()
                    r = http.post(path, content=body, headers=headers)
                    assert r.status_code == 200, r.text
                    return np.asarray(r.json()["tau"])

                def batch_npz():
                    r = http.post(path, content=npz_bytes(q=qb, v=vb, a=ab),
                                  headers={"Content-Type": NPZ, "Accept": NPZ})
                    assert r.status_code == 200, r.text
                    with np.load(io.BytesIO(r.content), allow_pickle=False) as z:
                        return z["tau"]

                ref = dynamics.inverse_dynamics(model, qb, vb, ab)
                assert np.array_equal(batch_json(), ref) and np.array_equal(batch_npz(), ref)

                for fn in (trivial, single):  # warm the connection, the cache and the code paths
                    latencies(fn, 200)
                # interleaved, so that the load of a shared machine falls on both alike
                lat_trivial, lat_single = np.empty(args.n), np.empty(args.n)
                for i in range(args.n):
                    lat_trivial[i] = latencies(trivial, 1)[0]
                    lat_single[i] = latencies(single, 1)[0]
                lat_lib = latencies(lambda: dynamics.inverse_dynamics(model, q1, v1, a1), args.n)
                t_lib = best(lambda: dynamics.inverse_dynamics(model, qb, vb, ab), args.repeat)
                t_json = best(batch_json, args.repeat)
                t_npz = best(batch_npz, args.repeat)
                t_triv = float(np.min(lat_trivial))
        finally:
            proc.terminate()
            proc.wait(15)

    def ms(x):
        return f"{x * 1e3:.3f}"

    p50 = {k: float(np.percentile(v, 50)) for k, v in
           {"trivial": lat_trivial, "single": lat_single, "lib": lat_lib}.items()}
    p99 = {k: float(np.percentile(v, 99)) for k, v in
           {"trivial": lat_trivial, "single": lat_single, "lib": lat_lib}.items()}
    single_ratio = p50["single"] / p50["trivial"]
    npz_limit = 2 * t_lib + 0.010
    rows = [
        "| measurement | req/s | p50 ms | p99 ms | ratio to library | ratio to trivial endpoint | target |",
        "|---|---:|---:|---:|---:|---:|---|",
        f"| trivial endpoint GET /v1/health | {1 / np.mean(lat_trivial):.0f} | {ms(p50['trivial'])} | "
        f"{ms(p99['trivial'])} | | 1.00 | |",
        f"| library inverse_dynamics, 1 state (in process) | {1 / np.mean(lat_lib):.0f} | {ms(p50['lib'])} | "
        f"{ms(p99['lib'])} | 1.00 | | |",
        f"| POST inverse-dynamics, 1 state, JSON | {1 / np.mean(lat_single):.0f} | {ms(p50['single'])} | "
        f"{ms(p99['single'])} | {p50['single'] / p50['lib']:.1f} | {single_ratio:.2f} | "
        f"<= 1.5x trivial: {'met' if single_ratio <= 1.5 else 'MISSED'} |",
        f"| library inverse_dynamics, {args.batch} states | | {ms(t_lib)} | | 1.00 | {t_lib / t_triv:.1f} | |",
        f"| POST inverse-dynamics, {args.batch} states, JSON | | {ms(t_json)} | | {t_json / t_lib:.2f} | "
        f"{t_json / t_triv:.1f} | |",
        f"| POST inverse-dynamics, {args.batch} states, .npz | | {ms(t_npz)} | | {t_npz / t_lib:.2f} | "
        f"{t_npz / t_triv:.1f} | <= 2x library + 10 ms = {ms(npz_limit)} ms: "
        f"{'met' if t_npz <= npz_limit else 'MISSED'} |",
    ]
    header = (f"Robot {args.robot} (nq={model.nq}), {args.n} sequential single-state requests per endpoint over one "
              f"keep-alive connection, batches best of {args.repeat}; {os.cpu_count()} CPUs, Python "
              f"{sys.version.split()[0]}, uvicorn (h11) with one server process.")
    table = header + "\n\n" + "\n".join(rows) + "\n"
    print(table)
    out = REPO / "benchmarks" / "out"
    out.mkdir(exist_ok=True)
    (out / "service.md").write_text(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
