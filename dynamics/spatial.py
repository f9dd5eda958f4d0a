"""Rotations the URDF reader needs at load time (plain numpy).  The spatial algebra of the kernels, and its
conventions (motion (w, v), force (n, f), transforms (R, p), inertias (m, h, Io); Featherstone 2008, ch. 2), is the
core's: ``core/spatial.hpp``.
"""

import numpy as np


def rpy_to_matrix(rpy):
    """URDF roll-pitch-yaw to a rotation matrix: R = Rz(yaw) Ry(pitch) Rx(roll) (plain numpy, load time).  Each
    entry's products are grouped as in trimesh's ``euler_matrix(.., 'sxyz')``, which the URDF reader used before
    it read origins itself, so models keep their bits (Pinocchio's quaternion route is within 8e-16 of it)."""
    r, p, y = rpy
    sr, sp, sy = np.sin(r), np.sin(p), np.sin(y)
    cr, cp, cy = np.cos(r), np.cos(p), np.cos(y)
    return np.array([
        [cp * cy, sp * (sr * cy) - cr * sy, sp * (cr * cy) + sr * sy],
        [cp * sy, sp * (sr * sy) + cr * cy, sp * (cr * sy) - sr * cy],
        [-sp, cp * sr, cp * cr],
    ])


def matrix_to_rpy(R):
    """A rotation matrix to URDF roll-pitch-yaw (the inverse of :func:`rpy_to_matrix`; pitch in [-pi/2, pi/2]).  At
    pitch = +-pi/2 (gimbal lock) roll and yaw share one axis: roll is 0 and yaw takes the whole angle."""
    R = np.asarray(R, dtype=float)
    sp = -R[2, 0]
    p = np.arctan2(sp, np.hypot(R[0, 0], R[1, 0]))
    if np.hypot(R[0, 0], R[1, 0]) < 1e-12:  # gimbal lock: R = Rz(yaw) Ry(+-pi/2) with the roll folded into yaw
        return np.array([0.0, p, np.arctan2(-R[0, 1], R[1, 1])])
    return np.array([np.arctan2(R[2, 1], R[2, 2]), p, np.arctan2(R[1, 0], R[0, 0])])
