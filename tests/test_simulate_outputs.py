"""Simulation keeps only what was asked for, and refuses a singular robot up front."""

import numpy as np
import pytest

import dynamics
from robots import REPO, chain_urdf


@pytest.fixture(scope="module")
def arm():
    return dynamics.load_urdf(f"{REPO}/robots/planar_2r.urdf")


def test_outputs_subset_matches_the_full_run(arm):
    from dynamics.torques import PD

    pd = PD(np.zeros(2), 30.0, 3.0)
    full = dynamics.simulate(arm, [0.5, 0.2], [0, 0], 1.0, torque=pd, sample_dt=0.01, error_estimate="none")
    only_q = dynamics.simulate(arm, [0.5, 0.2], [0, 0], 1.0, torque=pd, sample_dt=0.01, error_estimate="none",
                               outputs=("q",))
    np.testing.assert_array_equal(only_q.t, full.t)
    np.testing.assert_array_equal(only_q.q, full.q)
    assert only_q.v.shape == (0, 2) and only_q.tau.shape == (0, 2)
    # the energy balance is then taken between the end states (same residual, scaled by the end states'
    # energies instead of the whole run's), and there is no per-sample maximum
    assert 0 < only_q.report["energy_drift"] < 1e-6
    assert full.report["energy_drift"] / 3 < only_q.report["energy_drift"] < 3 * full.report["energy_drift"]
    assert only_q.report["energy_drift_max"] is None
    with_tau = dynamics.simulate(arm, [0.5, 0.2], [0, 0], 1.0, torque=pd, sample_dt=0.01, error_estimate="none",
                                 outputs=("tau",))
    np.testing.assert_array_equal(with_tau.tau, full.tau)
    with pytest.raises(dynamics.InputError, match="outputs"):
        dynamics.simulate(arm, [0.5, 0.2], [0, 0], 1.0, outputs=("q", "acc"))


def test_singular_robot_is_refused_before_integrating():
    text = chain_urdf(2)  # a chain whose last link carries nothing
    head, tail = text.rsplit('<link name="link1">', 1)
    tail = tail.split("</link>", 1)[1]
    model = dynamics.load_urdf(head + '<link name="link1"/>' + tail)
    with pytest.raises(dynamics.InputError, match="singular at joint 'joint1'"):
        dynamics.simulate(model, [0.1, 0.2], [0, 0], 0.5)
