"""A chain of six capsule links falls onto the ground with friction (issue 19's proof): it ends lying on the
ground, and the energy it lost is what the contacts report as dissipated (plus what they still hold elastically),
to the run's own energy error."""

import numpy as np
import pytest

import dynamics

N, LENGTH, RADIUS, MASS = 6, 0.1, 0.015, 0.2


def chain_urdf():
    """Links along x, each a 0.2 kg rod of 0.1 m; joints alternate about y and z (no damping, no limits: only
    contact and friction take energy out)."""
    I_rod = MASS * LENGTH ** 2 / 12
    links = "".join(
        f'<link name="l{i}"><inertial><origin xyz="{LENGTH / 2} 0 0"/><mass value="{MASS}"/>'
        f'<inertia ixx="1e-5" iyy="{I_rod}" izz="{I_rod}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        for i in range(N))
    joints = "".join(
        f'<joint name="j{i}" type="continuous"><parent link="l{i - 1}"/><child link="l{i}"/>'
        f'<origin xyz="{LENGTH} 0 0"/><axis xyz="{"0 1 0" if i % 2 else "0 0 1"}"/></joint>'
        for i in range(1, N))
    return f'<robot name="chain">{links}{joints}</robot>'


def capsules():
    """Each link's capsule along its x axis (a capsule's axis is its local z)."""
    T = np.eye(4)
    T[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]  # local z -> link x
    T[0, 3] = LENGTH / 2
    return [dynamics.Capsule(f"l{i}", RADIUS, LENGTH, T) for i in range(N)]


def lowest_point(model, q, i):
    """The height of link i's lower axis end."""
    X = dynamics.frame_placement(model, q, f"l{i}")
    return min((X[:3, :3] @ [x, 0, 0] + X[:3, 3])[2] for x in (0.0, LENGTH))


@pytest.fixture(scope="module")
def fall():
    model = dynamics.load_urdf(chain_urdf(), floating_base=True)
    q0 = model.neutral()
    tilt = np.array([0.1, 0.05, 0.0, 1.0]) / np.linalg.norm([0.1, 0.05, 0.0, 1.0])  # (x, y, z, w)
    q0[:7] = (0.0, 0.0, 0.4, *tilt)
    q0[7:] = [0.4, -0.3, 0.3, 0.2, -0.4]
    lowest = min(lowest_point(model, q0, i) for i in range(N))
    assert 0.05 < lowest - RADIUS < 0.3  # it starts in the air
    v0 = np.zeros(model.nv)
    v0[:6] = (0.3, 0.0, 0.0, 0.5, -1.0, 2.0)
    contact = dynamics.Contact(geometries=capsules(), friction=0.6)
    traj = dynamics.simulate(model, q0, v0, 1.5, contact=contact, rtol=1e-7, atol=1e-9, error_estimate="none")
    return model, traj


def test_the_chain_ends_on_the_ground(fall):
    model, traj = fall
    rep = traj.report
    assert rep["status"] == "ok"
    q = traj.q[-1]
    for i in range(N):  # every link's axis at the capsules' radius above the ground, sunk by less than 2 mm
        X = dynamics.frame_placement(model, q, f"l{i}")
        for x in (0.0, LENGTH):
            z = (X[:3, :3] @ [x, 0, 0] + X[:3, 3])[2]
            assert RADIUS - 2e-3 < z < RADIUS + 1e-3, (i, x, z)
    assert np.abs(traj.v[-1]).max() < 1e-3  # at rest: friction stopped it
    c = rep["contact"]
    assert 0.5 < c["time_in_contact"] < 1.5 and 0 < c["max_penetration"] < 0.01


def test_the_energy_lost_is_the_reported_dissipation(fall):
    model, traj = fall
    rep = traj.report
    c = rep["contact"]
    lost = rep["energy_initial"] - rep["energy_final"]
    assert lost > 0.5 * MASS * N * 9.81 * 0.2  # most of the drop's potential energy and the spin's
    assert rep["work_passive"] == 0.0 and rep["work_torque"] == 0.0
    held = c["elastic_energy_final"] - c["elastic_energy_initial"]
    assert c["energy_dissipated"] + held == pytest.approx(lost, abs=10 * rep["energy_drift"] * rep["energy_scale"]
                                                          + 1e-9)
    assert rep["energy_drift"] < 1e-5
