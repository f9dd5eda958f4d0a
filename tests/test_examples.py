"""Every script in examples/ runs as a user would run it (the client example against a real server) and says
what it promises."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from service_fixtures import REPO, shared_server

EXAMPLES = REPO / "examples"


def run(name, *args, env=None, cwd):
    proc = subprocess.run([sys.executable, str(EXAMPLES / name), *args], capture_output=True, text=True,
                          timeout=600, cwd=cwd, env={**os.environ, **(env or {})})
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return proc.stdout


def test_every_example_is_tested():
    tested = {"01_dynamics_basics.py", "02_simulate_and_plot.py", "03_coming_from_pinocchio.py",
              "04_client.py", "05_training_data.py", "06_gym_environment.py"}
    assert {p.name for p in EXAMPLES.glob("*.py")} == tested


def test_basics(tmp_path):
    out = run("01_dynamics_basics.py", cwd=tmp_path)
    err = float(out.split("ABA(RNEA(a)) - a =")[1].split()[0])
    assert err < 1e-10 and "identity holds: True" in out and "positive definite: True" in out


def test_simulate_and_plot(tmp_path):
    out = run("02_simulate_and_plot.py", str(tmp_path / "t.png"), cwd=tmp_path)
    assert "status ok" in out and (tmp_path / "t.png").stat().st_size > 10_000


def test_coming_from_pinocchio(tmp_path):
    out = run("03_coming_from_pinocchio.py", cwd=tmp_path)
    assert float(out.split("after reorder:")[1].split()[0]) < 1e-9


def test_client(tmp_path_factory, tmp_path):
    server = shared_server(tmp_path_factory.getbasetemp())
    out = run("04_client.py", env={"DYNAMICS_URL": server.url}, cwd=tmp_path)
    assert float(out.split("from the library:")[1].split()[0]) < 1e-12 and "status ok" in out


def test_training_data(tmp_path):
    out = run("05_training_data.py", "5000", str(tmp_path / "d.npz"), cwd=tmp_path)
    assert "5000 states" in out and (tmp_path / "d.npz").exists()


def test_gym_environment(tmp_path):
    out = run("06_gym_environment.py", "8", "120", cwd=tmp_path)
    reached = int(out.split("goals reached:")[1].split()[0])
    worst = float(out.split("largest per-period error estimate:")[1].split(";")[0])
    failed = int(out.split("failed environments:")[1].split()[0])
    # the hand-written policy reaches goals 15 cm away in 1.2 s, the periods integrated within tolerance
    assert reached >= 8 and failed == 0 and worst < 1e-6, out
