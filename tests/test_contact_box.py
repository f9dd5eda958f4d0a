"""A box (free body, 8 corner contacts on a plane) on an incline and tumbling onto the ground (issue 19, section
5): stiction below tan(theta) = mu with the law's creep speed, sliding above it at a = g (sin theta - mu cos
theta); a tumbling box coming to rest with the energy it lost equal to the reported dissipation; and the
simulation's accelerations equal to the dynamics with contact_forces as f_ext (M a + b = J_c^T f_c)."""

import math

import numpy as np
import pytest

import dynamics

M, SIZE, G = 1.0, (0.2, 0.2, 0.1), 9.81
MU = 0.5
VS = 1e-3


def box_urdf():
    a, b, c = SIZE
    i = [M / 12 * (b * b + c * c), M / 12 * (a * a + c * c), M / 12 * (a * a + b * b)]
    return (f'<robot name="box"><link name="box"><inertial><mass value="{M}"/><inertia ixx="{i[0]}" iyy="{i[1]}" '
            f'izz="{i[2]}" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>')


@pytest.fixture(scope="module")
def box():
    return dynamics.load_urdf(box_urdf(), floating_base=True)


def incline(theta):
    n = (-math.sin(theta), 0.0, math.cos(theta))
    return dynamics.Contact(ground=dynamics.Ground(normal=n), friction=dynamics.Material(mu_static=MU,
                            stiction_velocity=VS), geometries=[dynamics.Box("box", SIZE)])


def resting_on(model, contact, theta):
    """The box on the incline at its static sinking (4 corners share m g cos theta), at rest."""
    k = M * G / contact.friction.penetration_allowance  # the default pair stiffness
    x = M * G * math.cos(theta) / (4 * k)
    n = np.array([-math.sin(theta), 0.0, math.cos(theta)])
    q = np.zeros(7)
    q[:3] = (SIZE[2] / 2 - x) * n
    q[3:7] = [0.0, math.sin(-theta / 2), 0.0, math.cos(-theta / 2)]  # the box's z axis along n
    return q, np.zeros(6)


def downhill(theta):
    return np.array([-math.cos(theta), 0.0, -math.sin(theta)])


def test_sticks_below_the_friction_angle_at_the_creep_speed(box):
    """tan(theta) = 0.3 < mu: the box creeps at the regularised law's speed v_s (1 - sqrt(1 - tan(theta)/mu))
    (friction mu_s s (2 - s) balancing m g sin(theta) over m g cos(theta) of normal force), below v_s."""
    theta = math.atan(0.3)
    contact = incline(theta)
    q0, v0 = resting_on(box, contact, theta)
    traj = dynamics.simulate(box, q0, v0, 0.5, contact=contact, error_estimate="none", rtol=1e-8, atol=1e-10)
    assert traj.report["status"] == "ok"
    d = downhill(theta)
    drift = (traj.q[-1, :3] - q0[:3]) @ d
    assert 0 <= drift <= VS * 0.5
    creep = VS * (1 - math.sqrt(1 - math.tan(theta) / MU))
    speed = (traj.q[-1, :3] - traj.q[-101, :3]) @ d / (traj.t[-1] - traj.t[-101])
    assert speed == pytest.approx(creep, rel=1e-4)


@pytest.fixture(scope="module")
def sliding(box):
    theta = math.atan(0.7)
    contact = dynamics.Contact(ground=dynamics.Ground(normal=(-math.sin(theta), 0, math.cos(theta))),
                               friction=dynamics.Material(mu_static=MU, stiction_velocity=VS),
                               geometries=[dynamics.Box("box", SIZE)])
    q0, v0 = resting_on(box, contact, theta)
    traj = dynamics.simulate(box, q0, v0, 0.4, contact=contact, rtol=1e-9, atol=1e-11, sample_dt=1e-3,
                             error_estimate="none")
    return theta, contact, traj


def test_slides_above_it_at_the_coulomb_acceleration(box, sliding):
    theta, contact, traj = sliding
    d = downhill(theta)
    # the free joint's v[:3] is the body-frame velocity: the frame velocity in world axes instead
    speed = np.array([dynamics.frame_velocity(box, q, v, "box")[:3] @ d
                      for q, v in zip(traj.q, traj.v)])
    i, j = np.searchsorted(traj.t, [0.1, 0.4 - 1e-9])
    a = (speed[j] - speed[i]) / (traj.t[j] - traj.t[i])
    want = G * (math.sin(theta) - MU * math.cos(theta))
    assert a == pytest.approx(want, rel=1e-3)


def test_accelerations_are_the_dynamics_with_contact_forces(box, sliding):
    """At every sample: a = forward_dynamics(f_ext = contact_forces) satisfies M a + b = J_c^T f_c (CRBA and
    RNEA, independent of the ABA), and the simulated v changes at that rate (central differences)."""
    theta, contact, traj = sliding
    zero = np.zeros(6)
    acc = []
    for q, v in zip(traj.q, traj.v):
        f_ext, det = dynamics.contact_forces(box, contact, q, v, details=True)
        a = dynamics.forward_dynamics(box, q, v, zero, f_ext=f_ext)
        lhs = dynamics.mass_matrix(box, q) @ a + dynamics.bias_forces(box, q, v)
        assert np.allclose(lhs, det.generalized_force, rtol=0, atol=1e-9 * (1 + np.abs(det.generalized_force).max()))
        assert np.allclose(dynamics.inverse_dynamics(box, q, v, a, f_ext=f_ext), 0.0, atol=1e-9)
        acc.append(a)
    acc = np.array(acc)
    h = traj.t[1] - traj.t[0]
    fd = (traj.v[2:] - traj.v[:-2]) / (2 * h)
    late = traj.t[1:-1] > 0.1
    assert np.abs(fd[late] - acc[1:-1][late]).max() < 1e-4 * np.abs(acc).max()


def test_tumbling_box_comes_to_rest_and_dissipates_what_it_lost(box):
    contact = dynamics.Contact(geometries=[dynamics.Box("box", SIZE)], friction=0.8)
    q0 = np.array([0.0, 0.0, 0.3, *np.array([0.3, 0.2, 0.1, 0.9]) / np.linalg.norm([0.3, 0.2, 0.1, 0.9])])
    v0 = np.array([0.5, 0.0, 0.0, 2.0, -3.0, 1.0])
    traj = dynamics.simulate(box, q0, v0, 2.0, contact=contact, rtol=1e-7, atol=1e-9, error_estimate="none")
    rep = traj.report
    assert rep["status"] == "ok"
    assert np.abs(traj.v[-1]).max() < 1e-3  # at rest
    assert min(abs(traj.q[-1, 2] - h / 2) for h in SIZE) < 2e-3  # on one of its faces (sunk < 2 mm)
    c = rep["contact"]
    E0, E1 = rep["energy_initial"], rep["energy_final"]
    lost = E0 - E1
    assert lost > 0.5
    # what the robot lost = what the contacts dissipated + what they still hold elastically
    assert c["energy_dissipated"] + c["elastic_energy_final"] - c["elastic_energy_initial"] == pytest.approx(
        lost, abs=10 * rep["energy_drift"] * rep["energy_scale"] + 1e-9)
    assert rep["energy_drift"] < 1e-5
    assert c["time_in_contact"] > 1.0 and 0 < c["max_penetration"] < 0.01
