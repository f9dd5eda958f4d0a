"""Masses and inertias outside what float64 dynamics can carry are refused or warned about at load, and a
singular mass matrix is explained by what the joint really moves (issue 25, item 7).

The robot: a planar 3R arm, links 1 m, each link 1 kg at its middle unless a test says otherwise.
"""

import subprocess
import sys

import numpy as np
import pytest

import dynamics
from dynamics import URDFError
from robots import erd


def arm(mass=("1", "1", "1"), com=("0.5", "0.5", "0.5"), inertia=("0.1", "0.1", "0.1")):
    s = '<robot name="arm"><link name="base"/>'
    prev = "base"
    for i in (1, 2, 3):
        m, c, I = mass[i - 1], com[i - 1], inertia[i - 1]
        s += (f'<link name="l{i}"><inertial><mass value="{m}"/><origin xyz="{c} 0 0"/>'
              f'<inertia ixx="{I}" iyy="{I}" izz="{I}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
              f'<joint name="j{i}" type="revolute"><parent link="{prev}"/><child link="l{i}"/>'
              f'<origin xyz="{0 if i == 1 else 1} 0 0"/><axis xyz="0 0 1"/>'
              f'<limit lower="-3" upper="3" effort="10" velocity="10"/></joint>')
        prev = f"l{i}"
    return s + "</robot>"


def test_a_mass_beyond_float64_dynamics_is_refused_naming_the_link():
    """Before: mass 1e308 loaded; forward dynamics answered "moves no mass", inverse dynamics NaN."""
    with pytest.raises(URDFError, match=r"link 'l2': mass 1e\+308 kg exceeds 1e\+12 kg"):
        dynamics.load_urdf(arm(mass=("1", "1e308", "1")))
    with pytest.raises(URDFError, match=r"link 'l2': mass 1e\+308 kg exceeds"):
        dynamics.load_urdf(arm(mass=("1", "1e308", "1")), strict_inertia=False)
    with pytest.raises(URDFError, match=r"link 'l3': inertia: principal moment 1e\+300 kg m\^2 exceeds 1e\+12"):
        dynamics.load_urdf(arm(inertia=("0.1", "0.1", "1e300")))
    # the heaviest machines (1.4e7 kg) load
    big = dynamics.load_urdf(arm(mass=("1.4e7", "1", "1"), inertia=("1e7", "0.1", "0.1")))
    assert big.masses[0] == 1.4e7


def test_a_mass_lost_in_the_round_off_of_the_robot_warns():
    """l3 at 1e-13 kg on a 2 kg arm: 5e-14 of the total."""
    model = dynamics.load_urdf(arm(mass=("1", "1", "1e-13"), inertia=("0.1", "0.1", "0")))
    [w] = [w for w in model.warnings if "round-off" in w]
    assert w.startswith("link 'l3': mass 1e-13 kg is 5e-14 of the robot's 2 kg")
    # so101 carries the smallest mass ratio of example-robot-data's robots (1e-9 kg on 0.63 kg): no warning
    so101 = dynamics.load_urdf(erd("so_arm_description/urdf/so101.urdf"))
    assert not [w for w in so101.warnings if "round-off" in w]


def _point_mass_on_the_last_axis():
    """l3 is a 1 kg point on joint j3's axis: j3 moves mass but no inertia about its axis; M is singular."""
    return dynamics.load_urdf(arm(com=("0.5", "0.5", "0"), inertia=("0.1", "0.1", "0")))


def test_a_singular_mass_matrix_is_explained_by_what_the_joint_moves():
    model = _point_mass_on_the_last_axis()
    q, v = np.zeros(3), np.zeros(3)
    honest = r"joint 'j3': the 1 kg below it has no inertia along its motion here"
    with pytest.raises(dynamics.InputError, match=honest):
        dynamics.forward_dynamics(model, q, v, v)
    with pytest.raises(dynamics.InputError, match=honest):
        dynamics.inverse_mass_matrix(model, q)
    with pytest.raises(dynamics.InputError, match=honest):
        dynamics.simulate(model, q, v, 0.1)
    # a joint that really moves nothing keeps the old words
    empty = dynamics.load_urdf(arm(mass=("1", "1", "0"), inertia=("0.1", "0.1", "0")))
    with pytest.raises(dynamics.InputError, match=r"joint 'j3': it moves no mass or inertia"):
        dynamics.forward_dynamics(empty, q, v, v)


def test_check_and_simulate_agree_on_a_joint_that_moves_no_inertia(tmp_path):
    """`dynamics check` said "ok" on the model `simulate` refuses (issue 25, item 9): one rule now."""
    path = tmp_path / "arm.urdf"
    path.write_text(arm(com=("0.5", "0.5", "0"), inertia=("0.1", "0.1", "0")))
    proc = subprocess.run([sys.executable, "-m", "dynamics", "check", str(path)], capture_output=True, text=True)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "refused by simulate and forward dynamics at the neutral configuration" in proc.stdout
    assert "joint 'j3': the 1 kg below it has no inertia along its motion here" in proc.stdout
    path.write_text(arm())
    proc = subprocess.run([sys.executable, "-m", "dynamics", "check", str(path)], capture_output=True, text=True)
    assert proc.returncode == 0 and "ok: arm loads" in proc.stdout, proc.stdout + proc.stderr
