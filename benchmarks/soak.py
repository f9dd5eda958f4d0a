"""Soak (issue 11 section 6): `python -m benchmarks.soak [--minutes 10] [--clients 8]`. Not in CI.

Starts the service (one simulation worker, two compute threads, a fresh store), then --clients threads send a
mix of requests for --minutes: health, single-state and batched dynamics in JSON and .npz, a 128-joint mass
matrix, short simulations, uploads / listings / deletes, and bad requests (a 4xx is their right answer). The
server's RSS is sampled every second. Passes when no answer is a 5xx (a 504 from a deliberately tiny
X-Time-Budget is counted apart) and the RSS of the last tenth of the run is within 10 % of the second tenth's
(the first tenth fills caches). Prints p50/p99 latency per kind of request as a markdown table.
"""

from __future__ import annotations

import argparse
import io
import json
import random
import sys
import tempfile
import threading
import time
from collections import Counter, defaultdict
from pathlib import Path

import httpx
import numpy as np

from benchmarks.service import REPO, start_server, stop, wait_for

sys.path.insert(0, str(REPO / "tests"))
from robots import chain_urdf  # noqa: E402  (the tests' URDF generator; tests/ is no package)

NPZ = "application/x-npz"
JSON_H = {"Content-Type": "application/json"}


def npz(**arrays) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return 0.0


def requests(chain: str, rng: random.Random):
    """(kind, method, path, kwargs) of one request of the mix."""
    q6 = np.random.default_rng(rng.randrange(1 << 30)).normal(size=(200, 6))
    mix = [
        ("health", "GET", "/v1/health", {}),
        ("id-1", "POST", "/v1/robots/puma560/inverse-dynamics",
         {"content": json.dumps({"q": q6[0].tolist(), "v": q6[1].tolist(), "a": q6[2].tolist()}), "headers": JSON_H}),
        ("id-200-npz", "POST", "/v1/robots/puma560/inverse-dynamics",
         {"content": npz(q=q6, v=q6, a=q6), "headers": {"Content-Type": NPZ, "Accept": NPZ}}),
        ("mm-200-json", "POST", "/v1/robots/puma560/mass-matrix",
         {"content": json.dumps({"q": q6.tolist()}), "headers": JSON_H}),
        ("mm128-1", "POST", f"/v1/robots/{chain}/mass-matrix",
         {"content": json.dumps({"q": [0.1] * 128}), "headers": JSON_H}),
        ("simulate", "POST", "/v1/robots/planar-2r/simulate",
         {"content": json.dumps({"q0": [0.3, 0.1], "v0": [0, 0], "duration": 0.5}), "headers": JSON_H}),
        ("list", "GET", "/v1/robots", {}),
        ("bad", "POST", "/v1/robots/puma560/inverse-dynamics",
         {"content": json.dumps({"q": [1.0] * 3, "v": "x"}), "headers": JSON_H}),
        ("too-large", "POST", f"/v1/robots/{chain}/mass-matrix",
         {"content": npz(q=np.zeros((5000, 128), np.float32)), "headers": {"Content-Type": NPZ}}),
        ("504", "POST", "/v1/robots/puma560/mass-matrix",
         {"content": npz(q=np.zeros((100_000, 6))), "headers": {"Content-Type": NPZ, "Accept": NPZ,
                                                                 "X-Time-Budget": "0.001"}}),
    ]
    return mix


def client(url: str, chain: str, end: float, seed: int, log: list, lock: threading.Lock) -> None:
    rng = random.Random(seed)
    mix = requests(chain, rng)
    with httpx.Client(base_url=url, timeout=60) as c:
        while time.monotonic() < end:
            if rng.random() < 0.05:  # upload, read back and delete a small robot
                n = rng.randrange(2, 10)
                t0 = time.perf_counter()
                r = c.post(f"/v1/robots?name=soak-{seed}-{n}", content=chain_urdf(n),
                           headers={"Content-Type": "application/xml"})
                if r.status_code in (200, 201):
                    c.delete(f"/v1/robots/{r.json()['id']}")
                kind, status = "upload+delete", r.status_code
            else:
                kind, method, path, kw = rng.choice(mix)
                t0 = time.perf_counter()
                status = c.request(method, path, **kw).status_code
            with lock:
                log.append((kind, status, time.perf_counter() - t0))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--minutes", type=float, default=10.0)
    p.add_argument("--clients", type=int, default=8)
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        server = start_server(Path(tmp) / "store", {"DYNAMICS_SIM_WORKERS": "1", "DYNAMICS_COMPUTE_THREADS": "2"})
        try:
            if not wait_for(server.url + "/v1/ready", time.monotonic() + 600):
                raise SystemExit("the service did not become ready")
            chain = httpx.post(server.url + "/v1/robots?name=chain128", content=chain_urdf(128),
                               headers={"Content-Type": "application/xml"}, timeout=60).json()["id"]
            log: list = []
            lock = threading.Lock()
            t_start = time.monotonic()
            end = t_start + args.minutes * 60
            threads = [threading.Thread(target=client, args=(server.url, chain, end, i, log, lock))
                       for i in range(args.clients)]
            for t in threads:
                t.start()
            rss = []
            while time.monotonic() < end:
                rss.append((time.monotonic() - t_start, rss_mb(server.proc.pid)))
                time.sleep(1.0)
            for t in threads:
                t.join()
        finally:
            stop(server)
    return report(log, rss, args)


def report(log, rss, args) -> int:
    statuses = Counter(s for _, s, _ in log)
    by_kind = defaultdict(list)
    for kind, status, seconds in log:
        by_kind[kind].append((status, seconds))
    fivexx = sum(n for s, n in statuses.items() if s >= 500 and s != 504)
    asked_504 = sum(1 for k, s, _ in log if k == "504" and s == 504)
    other_504 = statuses.get(504, 0) - asked_504
    t = np.array([x for x, _ in rss])
    mb = np.array([y for _, y in rss])
    span = t[-1] if len(t) else 0
    early = mb[(t >= span * 0.1) & (t < span * 0.2)]
    late = mb[t >= span * 0.9]
    early_mb, late_mb = float(np.median(early)), float(np.median(late))
    drift = (late_mb - early_mb) / early_mb
    print(f"## Soak: {args.minutes:g} min, {args.clients} clients, {len(log)} requests "
          f"({len(log) / (args.minutes * 60):.0f}/s)\n")
    print("| request | count | statuses | p50 ms | p99 ms |\n|---|---|---|---|---|")
    for kind, rows in sorted(by_kind.items()):
        secs = np.array([s for _, s in rows])
        st = ", ".join(f"{k}: {v}" for k, v in sorted(Counter(s for s, _ in rows).items()))
        print(f"| {kind} | {len(rows)} | {st} | {np.percentile(secs, 50) * 1e3:.1f} | "
              f"{np.percentile(secs, 99) * 1e3:.1f} |")
    all_s = np.array([s for _, _, s in log])
    print(f"| all | {len(log)} | | {np.percentile(all_s, 50) * 1e3:.1f} | {np.percentile(all_s, 99) * 1e3:.1f} |")
    print(f"\n5xx (other than the asked-for 504s): {fivexx + other_504}; RSS {early_mb:.0f} MB (10-20 % of the run) "
          f"-> {late_mb:.0f} MB (last 10 %), drift {drift * 100:+.1f} %, peak {mb.max():.0f} MB")
    ok = fivexx + other_504 == 0 and abs(drift) <= 0.10
    print("PASS" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
