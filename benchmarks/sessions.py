"""Sessions benchmark (issue 47, "over the network"): `python -m benchmarks.sessions [--n 5000] [--sessions 100]`.

Starts the service (`python -m service`, no simulation workers) on a free loopback port with an empty temporary
store, uploads the Panda of example-robot-data (mimic joints independent, as tests/test_simulator.py), then:

* the round trip of one Panda step over the WebSocket (`service.client.Simulator.step`, rk4, a 1 ms control
  period and a 1 ms substep, a PD source): median, p90 and p99 over --n steps after 500 of warm-up, next to the
  library's step in this process (`dynamics.Simulator.step`, the same scene) and the server's own step time
  (`stats["wall_time_s"]` / steps);
* --sessions concurrent sessions (one Panda environment each) opened, each stepped 10 times, then closed, for
  --rounds rounds: the server's RSS before the first round (after one session was opened and closed, so that the
  library, the model and the thread pools are in place), with the sessions held, and after they closed (once
  `GET /v1/sessions` lists none);
* a flood: --flood connections asked for by one key while it holds its limit of sessions, each refused (429 in
  an error frame): the refusals per second and the RSS before and after.

Target (issue 47): the round trip <= 0.3 ms median on loopback; memory back to its start after the sessions
close. The load average is printed with the table: this machine is shared, and a loaded one slows every hop.
Printed as markdown and written to benchmarks/out/sessions.md (git-ignored).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path

import httpx
import numpy as np
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

import dynamics
from benchmarks.service import REPO, start_server, stop, wait_for
from service.client import Client

Q0 = np.array([0.1, -0.4, 0.2, -2.0, 0.1, 1.6, 0.7, 0.02, 0.02])
OUT = REPO / "benchmarks" / "out" / "sessions.md"


def panda_path() -> str:
    sys.path.insert(0, str(REPO / "tests"))
    from robots import erd  # (the tests' locator of example-robot-data's files)
    return erd("panda_description/urdf/panda.urdf")


def rss_kib(pid: int) -> int:
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def listed(url: str) -> int:
    return len(httpx.get(url + "/v1/sessions").json()["sessions"])


def until_empty(url: str, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while listed(url) and time.monotonic() < end:
        time.sleep(0.05)
    assert listed(url) == 0, "sessions left after their connections closed"


def us(x: np.ndarray, q: float) -> str:
    return f"{np.percentile(x, q) * 1e6:.0f}"


def round_trip(robot, model, n: int) -> list[str]:
    pd = dynamics.torques.PD(kp=50.0, kd=5.0, q_target=Q0 + 0.2)
    tau = np.zeros(model.nv)
    here = dynamics.Simulator(model, Q0, np.zeros(model.nv), dt=1e-3, torque=pd, integrator="rk4", substep=1e-3)
    local = np.empty(n)
    remote = np.empty(n)
    with robot.simulator(Q0, np.zeros(model.nv), dt=1e-3, torque=pd, integrator="rk4", substep=1e-3) as sim:
        for _ in range(500):
            sim.step(tau)
            here.step(tau)
        # alternated, so that the machine's load falls on both alike
        for i in range(n):
            t0 = time.perf_counter()
            sim.step(tau)
            t1 = time.perf_counter()
            here.step(tau)
            t2 = time.perf_counter()
            remote[i], local[i] = t1 - t0, t2 - t1
        stats = sim.stats
    server = stats["wall_time_s"] / stats["steps"]
    return ["| Panda step, rk4, 1 ms period and substep | median (us) | p90 (us) | p99 (us) |", "|---|---|---|---|",
            f"| round trip over the WebSocket (client.Simulator.step) | {us(remote, 50)} | {us(remote, 90)} | "
            f"{us(remote, 99)} |",
            f"| the library's step in this process (dynamics.Simulator.step) | {us(local, 50)} | {us(local, 90)} | "
            f"{us(local, 99)} |",
            f"| the server's step (stats: wall time / steps, mean) | {server * 1e6:.0f} | | |"]


def concurrent(client, robot_id: str, url: str, pid: int, sessions: int, rounds: int) -> list[str]:
    robot = client.robot(robot_id)
    with robot.simulator(Q0, np.zeros(9), dt=1e-3, integrator="rk4"):  # the library, model and pools in place
        pass
    until_empty(url)
    time.sleep(0.5)
    start = rss_kib(pid)
    rows = ["| round | RSS before (MiB) | with the sessions held (MiB) | after they closed (MiB) | "
            "open+step+close (s) |",
            "|---|---|---|---|---|"]
    for k in range(rounds):
        before = rss_kib(pid)
        t0 = time.perf_counter()
        with ExitStack() as stack:
            sims = [stack.enter_context(robot.simulator(Q0, np.zeros(9), dt=1e-3, integrator="rk4"))
                    for _ in range(sessions)]
            assert listed(url) == sessions
            for _ in range(10):
                for sim in sims:
                    sim.step()
            held = rss_kib(pid)
        until_empty(url)
        seconds = time.perf_counter() - t0
        time.sleep(0.5)
        after = rss_kib(pid)
        rows.append(f"| {k + 1} | {before / 1024:.1f} | {held / 1024:.1f} | {after / 1024:.1f} | {seconds:.2f} |")
    rows.append("")
    rows.append(f"{sessions} sessions x {rounds} rounds: RSS {start / 1024:.1f} MiB before, "
                f"{rss_kib(pid) / 1024:.1f} MiB after ({(rss_kib(pid) - start) / 1024:+.1f} MiB).")
    return rows


def flood(url: str, pid: int, attempts: int, limit: int) -> list[str]:
    ws_url = url.replace("http://", "ws://") + "/v1/sessions"
    create = ('{"type": "create", "robot": "planar_2r", "q0": [0.3, -0.2], "v0": [0, 0], "dt": 0.01}')
    with ExitStack() as stack:
        for _ in range(limit):
            ws = stack.enter_context(connect(ws_url, compression=None))
            ws.send(create)
            ws.recv(timeout=60)
        before = rss_kib(pid)
        refused = 0
        t0 = time.perf_counter()
        for _ in range(attempts):
            with connect(ws_url, compression=None) as ws:
                if '"too_many_sessions"' in ws.recv(timeout=60):
                    refused += 1
                try:
                    ws.recv(timeout=60)
                except ConnectionClosed:
                    pass
        seconds = time.perf_counter() - t0
        after = rss_kib(pid)
        assert listed(url) == limit
    until_empty(url)
    return [f"A flood of {attempts} connections from one key holding its {limit} sessions: {refused} refused "
            f"(429 too_many_sessions) in {seconds:.1f} s ({attempts / seconds:.0f} a second); RSS "
            f"{before / 1024:.1f} MiB before, {after / 1024:.1f} MiB after."]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, default=5000, help="timed steps of the round trip")
    p.add_argument("--sessions", type=int, default=100, help="concurrent sessions")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--flood", type=int, default=10_000, help="connections asked for past the limit")
    args = p.parse_args(argv)
    path = panda_path()
    model = dynamics.load_urdf(path, mimic="independent")
    limit = args.sessions + 8
    with tempfile.TemporaryDirectory() as tmp:
        server = start_server(Path(tmp) / "store", {"DYNAMICS_SIM_WORKERS": "0",
                                                    "DYNAMICS_MAX_SESSIONS_PER_KEY": str(limit)})
        try:
            assert wait_for(server.url + "/v1/ready", time.monotonic() + 600)
            with Client(server.url, timeout=120) as client:
                robot = client.upload(path, name="panda", mimic="independent")
                rows = round_trip(robot, model, args.n)
                rows += [""] + concurrent(client, robot.id, server.url, server.proc.pid, args.sessions, args.rounds)
                rows += [""] + flood(server.url, server.proc.pid, args.flood, limit)
        finally:
            stop(server)
    header = (f"Loopback, one server process (uvicorn), the client in this process; {os.cpu_count()} CPUs, load "
              f"average {os.getloadavg()[0]:.1f} at the end; Python {sys.version.split()[0]}.")
    text = header + "\n\n" + "\n".join(rows) + "\n"
    print(text)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
