"""Errors that point at the likely mistake (a new user's first hour): a forgotten floating_base, a w-first
quaternion habit, strings for numbers, a full-length q for a model with locked joints."""

import numpy as np
import pytest

import dynamics
from robots import erd


@pytest.fixture(scope="module")
def solo_fixed():
    return dynamics.load_urdf(erd("solo_description/robots/solo12.urdf"))


def test_forgotten_floating_base(solo_fixed):
    assert solo_fixed.nq == 12
    with pytest.raises(dynamics.InputError, match=r"did you mean load_urdf\(\.\.\., floating_base=True\)"):
        dynamics.inverse_dynamics(solo_fixed, np.zeros(19), np.zeros(18), np.zeros(18))
    with pytest.raises(dynamics.InputError, match=r"v: .*floating_base=True"):
        dynamics.inverse_dynamics(solo_fixed, np.zeros(12), np.zeros(18), np.zeros(12))


def test_zero_quaternion_says_scalar_last():
    solo = dynamics.load_urdf(erd("solo_description/robots/solo12.urdf"), floating_base=True)
    q = solo.neutral()
    q[3:7] = 0.0
    with pytest.raises(dynamics.InputError, match=r"\(x, y, z, w\), scalar last.*\[0, 0, 0, 1\]"):
        dynamics.mass_matrix(solo, q)


@pytest.mark.parametrize("value, words", [
    (["0.1"] * 12, "got strings"),
    ([True] * 12, "got booleans"),
    ([[0.0] * 12, [0.0] * 11], "ragged"),
])
def test_wrong_kinds_are_named_in_words(solo_fixed, value, words):
    with pytest.raises(dynamics.InputError, match=words) as err:
        dynamics.mass_matrix(solo_fixed, value)
    assert "<U" not in str(err.value)


def test_full_length_q_on_a_locked_model(solo_fixed):
    locked = dynamics.lock_joints(solo_fixed, {"FL_HFE": 0.3, "FL_KFE": -0.6})
    with pytest.raises(dynamics.InputError, match=r"'FL_HFE', 'FL_KFE'\] locked") as err:
        dynamics.gravity_torques(locked, np.zeros(12))
    assert "10 coordinates" in str(err.value)


def test_a_batch_given_to_simulate_points_to_simulate_many():
    import numpy as np
    import dynamics
    model = dynamics.load_urdf(dynamics.robots.path("planar_2r"))
    with pytest.raises(dynamics.InputError, match=r"q0: expected shape \(2,\), got \(3, 2\).*simulate_many"):
        dynamics.simulate(model, np.zeros((3, 2)), np.zeros(2), 0.1)
    with pytest.raises(dynamics.InputError, match=r"v0: .*simulate_many"):
        dynamics.simulate(model, np.zeros(2), [[0.0, 0.0]] * 4, 0.1)
