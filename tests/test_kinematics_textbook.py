"""Kinematics of the textbook arms in robots/ against closed forms (issue 9, section 4).

The planar arms move in the world x-z plane (plane x = world x, plane y = world z, joint axes along plane z =
world -y; see the URDF headers).  Closed forms are written in plane coordinates (x, y) and compared with our
local_world_aligned Jacobians mapped to the plane: (x, y, z)_plane = (x, z, -y)_world.
"""

from pathlib import Path

import numpy as np
import pytest

import dynamics
from test_textbook import R2_L1, planar_2r_M

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
R2_L2 = 1.0  # the tip frame sits 1.0 m along link 2 (planar_2r.urdf)
RP_L1 = 0.4  # link 1's centre of mass, 0.4 m from the revolute axis (rp_arm.urdf)
RTOL = 1e-12


def to_plane(J):
    """Rows of a world-aligned 3 x n block in plane coordinates."""
    return np.array([J[0], J[2], -J[1]])


def planar_2r_jacobian(q):
    """The tip's linear Jacobian in the plane (Spong, Hutchinson & Vidyasagar, Robot Modeling and Control,
    ch. 4, the two-link planar arm)."""
    l1, l2 = R2_L1, R2_L2
    s1, c1, s12, c12 = np.sin(q[0]), np.cos(q[0]), np.sin(q[0] + q[1]), np.cos(q[0] + q[1])
    return np.array([[-l1 * s1 - l2 * s12, -l2 * s12], [l1 * c1 + l2 * c12, l2 * c12], [0.0, 0.0]])


def planar_2r_lambda(q):
    """Lambda = J^-T M J^-1 with the 2x2 Jacobian's inverse written out: J^-1 = 1/(l1 l2 s2) [[l2 c12, l2 s12],
    [-l1 c1 - l2 c12, -l1 s1 - l2 s12]]."""
    l1, l2 = R2_L1, R2_L2
    s1, c1, s12, c12 = np.sin(q[0]), np.cos(q[0]), np.sin(q[0] + q[1]), np.cos(q[0] + q[1])
    Jinv = np.array([[l2 * c12, l2 * s12], [-l1 * c1 - l2 * c12, -l1 * s1 - l2 * s12]]) / (l1 * l2 * np.sin(q[1]))
    return Jinv.T @ planar_2r_M(q) @ Jinv


def states(n, rng, lo, hi):
    return [rng.uniform(lo, hi) for _ in range(n)]


def test_planar_2r_end_effector_jacobian_and_lambda():
    arm = dynamics.load_urdf(ROBOTS / "planar_2r.urdf")
    rng = np.random.default_rng(0)
    for q in states(6, rng, [-np.pi, 0.3], [np.pi, 2.8]):  # away from the stretched-out singularity q2 = 0
        J = dynamics.frame_jacobian(arm, q, "tip")
        np.testing.assert_allclose(to_plane(J[:3]), planar_2r_jacobian(q), rtol=0, atol=RTOL)
        # angular: both joints turn about plane z = world -y
        np.testing.assert_allclose(J[3:], [[0, 0], [-1, -1], [0, 0]], atol=RTOL)
        T = dynamics.frame_placement(arm, q, "tip")
        x = R2_L1 * np.cos(q[0]) + R2_L2 * np.cos(q[0] + q[1])
        y = R2_L1 * np.sin(q[0]) + R2_L2 * np.sin(q[0] + q[1])
        np.testing.assert_allclose(T[:3, 3], [x, 0.0, y], atol=RTOL)
        # task-space inertia of the tip's position in the plane: world rows x and z
        Lam = dynamics.operational_space_inertia(arm, q, "tip", rows=[0, 2])
        ref = planar_2r_lambda(q)
        assert np.abs(Lam - ref).max() <= 1e-9 * np.abs(ref).max()


def test_planar_2r_stretched_out_is_singular():
    arm = dynamics.load_urdf(ROBOTS / "planar_2r.urdf")
    with pytest.raises(dynamics.InputError, match=r"frame 'tip'.*condition number"):
        dynamics.operational_space_inertia(arm, [0.4, 0.0], "tip", rows=[0, 2])
    Lam = dynamics.operational_space_inertia(arm, [0.4, 0.0], "tip", rows=[0, 2], damping=1e-4)
    assert np.all(np.isfinite(Lam)) and np.allclose(Lam, Lam.T)


def test_rp_arm_centre_of_mass_jacobians_as_in_the_lectures():
    """Jv1 = [[-l1 s1, 0], [l1 c1, 0], [0, 0]] and Jv2 = [[-d2 s1, c1], [d2 c1, s1], [0, 0]] at the links'
    centres of mass (link 2's is the link2 frame origin; link 1's is 0.4 m along link 1)."""
    arm = dynamics.load_urdf(ROBOTS / "rp_arm.urdf")
    rng = np.random.default_rng(1)
    for q in states(6, rng, [-np.pi, 0.1], [np.pi, 1.5]):
        s1, c1, d2 = np.sin(q[0]), np.cos(q[0]), q[1]
        Jv1 = to_plane(dynamics.frame_jacobian(arm, q, "link1", point=[RP_L1, 0, 0])[:3])
        Jv2 = to_plane(dynamics.frame_jacobian(arm, q, "link2")[:3])
        np.testing.assert_allclose(Jv1, [[-RP_L1 * s1, 0], [RP_L1 * c1, 0], [0, 0]], atol=RTOL)
        np.testing.assert_allclose(Jv2, [[-d2 * s1, c1], [d2 * c1, s1], [0, 0]], atol=RTOL)
        # the robot's centre of mass: (m1 l1 + m2 d2) / (m1 + m2) along link 1
        com = dynamics.center_of_mass(arm, q)
        r = (8.0 * RP_L1 + 5.0 * d2) / 13.0
        np.testing.assert_allclose(com, [r * c1, 0.0, r * s1], atol=RTOL)
        assert arm.total_mass == pytest.approx(13.0, abs=1e-12)
