"""Spatial algebra in one place (Featherstone, *Rigid Body Dynamics Algorithms*, 2008, ch. 2).

Conventions used by every kernel:

* A spatial motion vector is kept as two 3-vectors ``(w, v)``: angular velocity and the linear velocity of
  the point at the frame origin, both in the frame's coordinates (Featherstone's order, angular first).
* A spatial force is ``(n, f)``: moment about the frame origin and force, same coordinates.
* A transform from a child frame B to its parent P is ``(R, p)``: ``R`` = P_R_B (columns are B's axes in P)
  and ``p`` = B's origin in P.  Motion P -> B: ``w_B = R^T w_P``, ``v_B = R^T (v_P + w_P x p)``.
  Force B -> P: ``f_P = R f_B``, ``n_P = R n_B + p x (R f_B)`` (eq. 2.24-2.25 with X* = X^-T).
* A rigid-body inertia about the frame origin is ``(m, h, Io)``: mass, first moment ``h = m c`` and the
  rotational inertia about the origin ``Io = Ic + m [c]x^T [c]x``.  Its 6x6 form (angular first) is
  ``[[Io, [h]x], [[h]x^T, m 1]]`` (eq. 2.63).

3-vectors are tuples ``(x, y, z)`` and 3x3 matrices row-major 9-tuples, so that the kernels pass values in
registers: slicing a row out of a numba array makes a reference-counted view, which costs more than the
arithmetic here.  ``load3``/``store3`` move them between tuples and rows of the model's flat arrays.

The algebra is :data:`~dynamics._numba.helper` (numba's ``register_jitable``): compiled into each kernel that
calls it, with no entry point or cache file of its own; called from Python it runs as plain Python.  The
rotations Python code also uses (``_rotation_about_axis``, ``_quat_rotation``, ``_rotation_log``) are kernels.
"""

import numpy as np

# -- moving values between arrays and tuples -------------------------------------------------------

# -- 3-vectors and 3x3 matrices ------------------------------------------------------------------------

# -- spatial operations --------------------------------------------------------------------------------

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
