"""dynamics._numba.pack writes a value from Python in numba's own data layout: byte for byte what numba's
``pack_value`` stores (the compiled fallback), for the values the simulation packs and for a mix of scalar
types with padding."""

import numpy as np
from numba import njit

import dynamics
from dynamics import _numba
from dynamics import torques as T
from dynamics.simulation.problem import robot_problem
from dynamics.torques import SourceCall, kind_tag, make_source, source_workspace

from robots import OUR_ROBOTS


@njit
def _store_into(buf, x):
    _numba._store(buf, x)


def _same_as_numba(x):
    """Every byte numba's pack_value writes is ours (the bytes it leaves alone, padding, are zero in ours)."""
    ours = _numba.pack(x).view(np.uint8)
    zeros, ones = np.zeros(ours.size, np.uint8), np.full(ours.size, 255, np.uint8)
    _store_into(zeros.view(np.int64), x)
    _store_into(ones.view(np.int64), x)
    written = zeros == ones
    np.testing.assert_array_equal(ours[written], zeros[written])
    assert not ours[~written].any()
    assert written.mean() > 0.5


def test_pack_matches_numba_layout_for_simulation_values():
    arm = dynamics.load_urdf(f"{OUR_ROBOTS}/planar_2r.urdf")
    ps = T.Passive(np.zeros(2), np.ones(2), 1e-3, 1, -np.ones(2), np.ones(2), np.arange(2), 1e4, 1e2,
                   np.array([0.0, 0.0, -9.81]), np.zeros((0, 6)))
    src = make_source(arm, T.Target("tip", [1.2, 0.0, 0.9], kp=100.0, kd=20.0, rows=[0, 2]))
    _same_as_numba(SourceCall(src, arm.tree, ps, source_workspace(src, 2, 2), kind_tag(src.kind)))
    _same_as_numba(robot_problem(arm, ps, make_source(arm, None), np.zeros(2), np.zeros(3), ("q", "v")))


def test_pack_matches_numba_layout_with_padding():
    _same_as_numba((True, np.int32(-3), 2.5, np.arange(6.0).reshape(2, 3)[:, ::2], None, (np.uint8(7), 1)))
