"""``model.neutral()`` respects the joint limits, as MuJoCo's qpos0 is clamped into them (issue 25, item 9).

Panda's joint 4 has limits [-3.0718, -0.0698] rad: zero lies outside them, and at zero the elbow is stretched
straight (a singular arm).  The middle of the range, -1.5708 rad, is the elbow bent at a right angle (the
"ready" pose of Franka's own examples has -2.356).
"""

import numpy as np
import pytest

import dynamics
from dynamics.torques import Target
from robots import erd


@pytest.fixture(scope="module")
def panda():
    return dynamics.load_urdf(erd("panda_description/urdf/panda.urdf"), mimic="independent")


def test_neutral_is_within_the_limits(panda):
    q = panda.neutral()
    lo, hi = panda.lower, panda.upper
    assert np.all((lo <= q) & (q <= hi)), q
    # zero where zero is allowed, the middle of the range where it is not (joint 4 only)
    expected = np.zeros(9)
    expected[3] = (-3.0718 - 0.0698) / 2
    np.testing.assert_array_equal(q, expected)


def test_neutral_of_one_sided_and_free_joints():
    """A prismatic joint limited to [0.2, inf) starts at its bound; a free joint at the identity."""
    urdf = ('<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/>'
            '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>'
            '<joint name="s" type="prismatic"><parent link="a"/><child link="b"/><axis xyz="1 0 0"/>'
            '<limit lower="0.2" effort="1" velocity="1"/></joint></robot>')
    model = dynamics.load_urdf(urdf, floating_base=True)
    np.testing.assert_array_equal(model.neutral(), [0, 0, 0, 0, 0, 0, 1, 0.2])


def test_ik_and_operational_space_from_neutral(panda):
    """From the neutral pose, the hand 5 cm away: IK converges, and the operational-space controller tracks
    it (before: from q4 = 0, outside the limits and singular, the simulation failed)."""
    q0 = panda.neutral()
    T0 = dynamics.frame_placement(panda, q0, "panda_hand")
    target = T0.copy()
    target[:3, 3] += [0.05, 0.05, -0.05]
    q, rep = dynamics.inverse_kinematics(panda, "panda_hand", target, q0)
    assert rep["status"] == "converged"
    np.testing.assert_allclose(dynamics.frame_placement(panda, q, "panda_hand"), target, atol=1e-9)
    src = Target("panda_hand", target[:3, 3], T0[:3, :3], kp=100.0, kd=20.0, posture=q0, posture_kp=10.0)
    tr = dynamics.simulate(panda, q0, np.zeros(9), 3.0, torque=src, rtol=1e-9, atol=1e-11, sample_dt=0.5)
    assert tr.report["status"] == "ok"
    Tf = dynamics.frame_placement(panda, tr.q[-1], "panda_hand")
    assert np.abs(Tf[:3, 3] - target[:3, 3]).max() < 1e-5
