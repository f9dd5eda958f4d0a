"""dynamics.spatial.matrix_to_rpy (the service writes loop anchors' URDF rpy with it) against SciPy's extrinsic
x-y-z Euler angles and as the inverse of rpy_to_matrix, gimbal lock included."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dynamics.spatial import matrix_to_rpy, rpy_to_matrix


def test_random_rotations_agree_with_scipy():
    for R in Rotation.random(500, random_state=3).as_matrix():
        rpy = matrix_to_rpy(R)
        np.testing.assert_allclose(rpy, Rotation.from_matrix(R).as_euler("xyz"), atol=1e-12)
        np.testing.assert_allclose(rpy_to_matrix(rpy), R, atol=1e-14)


@pytest.mark.parametrize("pitch", [np.pi / 2, -np.pi / 2])
@pytest.mark.parametrize("roll, yaw", [(0.3, -1.1), (0.0, 0.0), (2.0, 2.5)])
def test_gimbal_lock_keeps_the_rotation(roll, yaw, pitch):
    R = rpy_to_matrix([roll, pitch, yaw])
    rpy = matrix_to_rpy(R)
    assert rpy[0] == 0.0 and rpy[1] == pytest.approx(pitch)
    np.testing.assert_allclose(rpy_to_matrix(rpy), R, atol=1e-14)


def test_identity_and_axes():
    np.testing.assert_array_equal(matrix_to_rpy(np.eye(3)), np.zeros(3))
    for k, angle in ((0, 0.4), (1, -0.7), (2, 3.0)):
        rpy = np.zeros(3)
        rpy[k] = angle
        np.testing.assert_allclose(matrix_to_rpy(rpy_to_matrix(rpy)), rpy, atol=1e-15)
