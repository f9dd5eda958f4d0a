"""Helpers shared by the service tests: a real uvicorn server process on a free loopback port.

Not a conftest: the test modules import what they need. One default server is shared by every module of the
session (:func:`shared_server`), because each start imports the library in the server and in its simulation
worker (a second or two of a core). :meth:`Server.start` returns at the first 200 of ``/v1/ready`` (or of
``/v1/health`` with ``ready=False``): both answer as soon as the server has started.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from service.client import ServiceError
from service.settings import Settings

REPO = Path(__file__).resolve().parent.parent
ROBOTS = REPO / "robots"
PYTHON = sys.executable


@contextlib.contextmanager
def in_process_app(store: Path, **settings):
    """The app in this process behind FastAPI's TestClient: the bundled robots, no simulation workers (simulate
    answers 501), one compute thread; ``settings`` override the rest."""
    config = Settings(**{"store_dir": store, "robots_dir": ROBOTS, "sim_workers": 0, "compute_threads": 1,
                         **settings})
    with TestClient(create_app(config)) as client:
        yield client


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    """``python -m service`` in a child process; ``url`` once :meth:`start` returned."""

    def __init__(self, store: Path, *, env: dict[str, str] | None = None, cwd: Path | None = None,
                 python: str = PYTHON, args: list[str] | None = None):
        self.store = Path(store)
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.cwd = Path(cwd) if cwd else self.store.parent
        self.python = python
        self.args = args or []
        # PYTHONPATH: the server imports the code under test, not whatever checkout the interpreter has installed
        self.env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")])),
                    "DYNAMICS_ROBOTS_DIR": str(ROBOTS), "DYNAMICS_SIM_WORKERS": "1",
                    # a request's budget long enough for a loaded 2-core machine; the budget tests set theirs
                    "DYNAMICS_TIME_BUDGET": "300",
                    "DYNAMICS_COMPUTE_THREADS": "2", **(env or {})}
        self.proc: subprocess.Popen | None = None
        self.log = self.cwd / f"server-{self.port}.log"

    def start(self, timeout: float = 120.0, ready: bool = True) -> "Server":
        """Start the process; return once it answers ``/v1/ready`` (``ready``) or ``/v1/health`` with 200."""
        self.cwd.mkdir(parents=True, exist_ok=True)
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen(
                [self.python, "-m", "service", "--host", "127.0.0.1", "--port", str(self.port),
                 "--store", str(self.store), "--log-level", "warning", *self.args],
                cwd=self.cwd, env=self.env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server exited with {self.proc.returncode}:\n{self.log.read_text()[-3000:]}")
            try:
                if httpx.get(self.url + ("/v1/ready" if ready else "/v1/health"), timeout=1.0).status_code == 200:
                    return self
            except httpx.TransportError:
                pass
            time.sleep(0.1)
        self.stop()
        raise RuntimeError(f"server did not answer within {timeout} s:\n{self.log.read_text()[-3000:]}")

    def kill(self) -> None:
        """SIGKILL the server and its process group (simulation workers included), as a crash would."""
        if self.proc and self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(10)

    def kill_alone(self) -> None:
        """SIGKILL the server process only, as the OOM killer or ``kill -9 PID`` would: its children are left to
        notice by themselves."""
        if self.proc and self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGKILL)
            self.proc.wait(10)

    def stop(self) -> None:
        if self.proc and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                pass
            try:  # whatever is left of the group (workers whose parent was stopped)
                os.killpg(self.proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self.proc.wait(10)

    def rss_kib(self) -> int:
        with open(f"/proc/{self.proc.pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
        return 0


_shared: dict[str, Server] = {}


def shared_server(tmp_root: Path) -> Server:
    """The session's default server (no API keys, default limits), started on first use."""
    if "default" not in _shared:
        server = Server(tmp_root / "store").start()
        _shared["default"] = server
        atexit.register(server.stop)
    return _shared["default"]


def while_simulation_starts(call, timeout: float = 300.0):
    """Run ``call()`` (a simulate request) until a simulation worker is there to take it.

    A worker killed past a budget is replaced by one that imports the library before it takes jobs, and a
    request's time budget counts its wait for a worker too (503 when every worker stayed busy until then, 504
    when the run did not fit what was left): both are retried.  501 (simulation off on this server) skips the
    test.
    """
    end = time.monotonic() + timeout
    while True:
        try:
            return call()
        except ServiceError as e:
            if e.status == 501:
                pytest.skip("this build of dynamics has no simulate()")
            if e.status not in (503, 504) or time.monotonic() > end:
                raise
            time.sleep(1.0)
