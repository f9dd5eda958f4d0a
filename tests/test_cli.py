"""The command line (`python -m dynamics`, installed as `dynamics`): real subprocesses, compared with the
library's own answers."""

import json
import subprocess
import sys

import numpy as np
import pytest

import dynamics
from dynamics.torques import PD


def run(*args, check=None):
    proc = subprocess.run([sys.executable, "-m", "dynamics", *args], capture_output=True, text=True, timeout=300)
    if check is not None:
        assert proc.returncode == check, proc.stdout + proc.stderr
    return proc


def test_info_json_lists_joints_with_slices_and_frames():
    out = json.loads(run("info", "puma560", "--json", check=0).stdout)
    model = dynamics.load_urdf(dynamics.robots.path("puma560"))
    assert [j["name"] for j in out["joints"]] == list(model.joint_names)
    assert out["joints"][2]["q"] == [2, 3] and out["nv"] == model.nv
    assert set(out["frames"]) == set(model.frames)


def test_info_text_and_help():
    text = run("info", dynamics.robots.path("planar_2r"), check=0).stdout
    assert "nq=2 nv=2" in text and "joint" in text
    assert "simulate" in run("--help", check=0).stdout
    assert "--torque" in run("simulate", "--help", check=0).stdout


def test_check_exit_codes(tmp_path):
    assert "ok:" in run("check", "rp_arm", check=0).stdout
    bad = tmp_path / "bad.urdf"
    bad.write_text('<robot name="r"><link name="a"/><link name="b"><inertial><mass value="-1"/>'
                   '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
                   '<joint name="j" type="revolute"><parent link="a"/><child link="b"/></joint></robot>')
    out = run("check", str(bad), check=1).stdout
    assert "refused" in out and "negative mass" in out


def test_simulate_matches_the_library(tmp_path):
    npz, png = tmp_path / "run.npz", tmp_path / "run.png"
    out = run("simulate", "planar_2r", "--duration", "0.5", "--q0", "0.5,0.2", "--torque",
              "pd:kp=400,kd=40,target=0.1,0.2", "--out", str(npz), "--plot", str(png), "--json", check=0)
    report = json.loads(out.stdout)
    model = dynamics.load_urdf(dynamics.robots.path("planar_2r"))
    ref = dynamics.simulate(model, [0.5, 0.2], [0, 0], 0.5, torque=PD(np.array([0.1, 0.2]), 400.0, 40.0))
    saved = np.load(npz)
    np.testing.assert_array_equal(saved["q"], ref.q)
    assert report["status"] == "ok" and report["steps"] == ref.report["steps"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("args, words", [
    (("simulate", "planar_2r", "--duration", "1", "--torque", "magic"), "unknown kind 'magic'"),
    (("simulate", "planar_2r", "--duration", "1", "--q0", "1,x"), "--q0: expected numbers"),
    (("simulate", "planar_2r", "--duration", "1", "--q0", "1,2,3"), "q0: expected shape (2,)"),
    (("info", "no_such_robot"), "neither URDF text nor an existing file"),
])
def test_bad_arguments_are_one_clear_line(args, words):
    proc = run(*args, check=1)
    assert words in proc.stderr and "Traceback" not in proc.stderr


def test_serve_forwards_to_the_service():
    assert "--port" in run("serve", "--help", check=0).stdout


def test_strict_exits_non_zero_on_a_report_warning():
    """Issue 25 C10: the 2R arm's default simulation reports error_estimate 14 with a warning and status "ok";
    --strict makes any report warning a failure (exit 2, the code of a simulation that is not ok)."""
    model = dynamics.load_urdf(dynamics.robots.path("planar_2r"))
    args = ("simulate", "planar_2r", "--duration", "10", "--q0", "1.0,0.5", "--json")
    report = dynamics.simulate(model, np.array([1.0, 0.5]), np.zeros(model.nv), 10.0).report
    if not report["warnings"]:
        pytest.skip("the library no longer warns on this run")
    assert json.loads(run(*args, check=0).stdout)["warnings"] == report["warnings"]
    proc = run(*args, "--strict", check=2)
    assert "--strict" in proc.stderr and report["warnings"][0][:40] in proc.stderr
    run("simulate", "planar_2r", "--duration", "0.1", "--strict", check=0)  # no warning, no failure


def test_a_simulation_out_of_steps_exits_2_as_documented():
    """The docs: a bad argument exits 1, a simulation that does not end "ok" exits 2; --duration 1e300 runs out
    of steps (it exited 1)."""
    proc = run("simulate", "planar_2r", "--duration", "1e300", check=2)
    assert "max_steps" in proc.stderr and "Traceback" not in proc.stderr


def test_info_into_a_closed_pipe_and_frames_in_model_order():
    """Issue 25 D16: `dynamics info ROBOT --json | head` ended in a BrokenPipeError traceback; frames were listed
    alphabetically and the text cut after 20."""
    proc = subprocess.run(f"'{sys.executable}' -m dynamics info stewart_platform --json | true", shell=True,
                          capture_output=True, text=True, timeout=300)
    assert "Traceback" not in proc.stderr and "BrokenPipe" not in proc.stderr, proc.stderr
    model = dynamics.load_urdf(dynamics.robots.path("stewart_platform"))
    out = json.loads(run("info", "stewart_platform", "--json", check=0).stdout)
    assert out["frames"] == list(model.frame_names)
    text = run("info", "stewart_platform", check=0).stdout
    assert ", ".join(model.frame_names) in text and len(model.frame_names) > 20


def test_serve_help_is_a_proper_help():
    out = run("serve", "--help", check=0).stdout
    assert out.startswith("usage: dynamics serve") and "``" not in out and "python -m service [" not in out
    assert "--port" in out and "--store" in out


def test_load_urdf_takes_the_bundled_names_the_cli_takes(tmp_path):
    """Issue 25 D14: load_urdf("puma560") failed while `dynamics info puma560` worked; a near miss names the
    closest, and a xacro file says to run xacro first."""
    assert dynamics.load_urdf("puma560").nq == dynamics.load_urdf(dynamics.robots.path("puma560")).nq
    assert dynamics.load_urdf("planar-2r").nq == 2  # the service's old spelling
    with pytest.raises(dynamics.URDFError, match="did you mean 'puma560'"):
        dynamics.load_urdf("puma56")
    xacro = tmp_path / "arm.urdf.xacro"
    xacro.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="a"><xacro:property name="l" '
                     'value="1"/><link name="base"/></robot>')
    with pytest.raises(dynamics.URDFError, match="run xacro first"):
        dynamics.load_urdf(str(xacro))
    assert {"four_bar", "cassie_like_leg", "stewart_platform"} <= set(dynamics.robots.names())
