"""Kinematic identities on random trees and real robots (issue 9, section 4): J v is the frame velocity;
placements by finite differences against J; the classical acceleration is J a + Jdot v; M equals the lectures'
sum over the bodies' centre-of-mass Jacobians; Lambda equals (J M^-1 J^T)^-1 from explicit matrices; M^-1 M = 1;
batches equal single calls.
"""

import numpy as np
import pytest

import dynamics
from robots import erd, random_state, random_urdf
from dynamics import _core

REFS = ("world", "local", "local_world_aligned")


def random_model(seed, n_links=9):
    rng = np.random.default_rng(seed)
    text = random_urdf(rng, n_links=n_links, floating_joint=seed % 3 == 0)
    return dynamics.load_urdf(text, floating_base=seed % 3 == 1), rng


@pytest.mark.parametrize("seed", range(6))
def test_jacobian_times_v_is_the_frame_velocity_and_classical_acceleration_is_J_a_plus_bias(seed):
    model, rng = random_model(seed)
    q, v, a = random_state(model, rng)
    for f in rng.integers(0, len(model.frame_names), 5):
        for ref in REFS:
            J = dynamics.frame_jacobian(model, q, int(f), reference=ref)
            vel = dynamics.frame_velocity(model, q, v, int(f), reference=ref)
            np.testing.assert_allclose(J @ v, vel, rtol=0, atol=1e-12 * max(1, np.abs(vel).max()))
            acc = dynamics.frame_acceleration(model, q, v, a, int(f), reference=ref)
            bias = dynamics.frame_bias_acceleration(model, q, v, int(f), reference=ref)
            np.testing.assert_allclose(J @ a + bias, acc, rtol=0, atol=1e-12 * max(1, np.abs(acc).max()))


@pytest.mark.parametrize("seed", range(4))
def test_placements_by_finite_differences_against_the_jacobian(seed):
    """(p(q + h v) - p(q - h v)) / 2h = J_lin v and log(R(q + h v) R(q - h v)^T) / 2h = J_ang v (world axes),
    moving on the configuration manifold (dynamics.integrate), for a point offset too."""
    model, rng = random_model(10 + seed)
    q, v, _ = random_state(model, rng)
    h = 1e-6
    point = rng.normal(size=3)
    T = dynamics.forward_kinematics(model, np.array([dynamics.integrate(model, q, v, s) for s in (h, -h)]))
    for f in rng.integers(0, len(model.frame_names), 5):
        J = dynamics.frame_jacobian(model, q, int(f), point=point)
        Tp, Tm = T[0, f], T[1, f]
        dp = (Tp[:3, :3] @ point + Tp[:3, 3] - Tm[:3, :3] @ point - Tm[:3, 3]) / (2 * h)
        dw = _core.rotation_log(np.ascontiguousarray(Tp[:3, :3] @ Tm[:3, :3].T)) / (2 * h)
        scale = max(1.0, np.abs(J @ v).max())
        np.testing.assert_allclose(dp, (J @ v)[:3], rtol=0, atol=1e-6 * scale)
        np.testing.assert_allclose(dw, (J @ v)[3:], rtol=0, atol=1e-6 * scale)
    # the centre of mass the same way
    C = dynamics.center_of_mass(model, np.array([dynamics.integrate(model, q, v, s) for s in (h, -h)]))
    vcom = dynamics.center_of_mass_velocity(model, q, v)
    np.testing.assert_allclose((C[0] - C[1]) / (2 * h), vcom, rtol=0, atol=1e-6 * max(1, np.abs(vcom).max()))
    np.testing.assert_allclose(dynamics.com_jacobian(model, q) @ v, vcom, rtol=0, atol=1e-12 * max(1, np.abs(vcom).max()))


@pytest.mark.parametrize("seed", range(4))
def test_mass_matrix_is_the_sum_over_centre_of_mass_jacobians(seed):
    """M = sum_i (m_i Jv_i^T Jv_i + Jw_i^T R_i I_i R_i^T Jw_i), Jv_i the Jacobian of body i's centre of mass
    (a point offset on the body's link frame), Jw_i its angular rows, I_i its inertia about the centre of mass."""
    model, rng = random_model(20 + seed)
    q, _, _ = random_state(model, rng)
    M = np.zeros((model.nv, model.nv))
    for i, link in enumerate(model.body_names):
        body, T = model.frames[link]
        assert body == i and np.allclose(T, np.eye(4))  # a body's link frame is its body frame
        J = dynamics.frame_jacobian(model, q, link, point=model.coms[i])
        R = dynamics.frame_placement(model, q, link)[:3, :3]
        M += model.masses[i] * J[:3].T @ J[:3] + J[3:].T @ R @ model.inertias[i] @ R.T @ J[3:]
    ref = dynamics.mass_matrix(model, q)
    np.testing.assert_allclose(M, ref, rtol=0, atol=1e-11 * np.abs(ref).max())


@pytest.mark.parametrize("seed", range(4))
def test_inverse_mass_matrix_times_M_is_identity_and_lambda_matches_explicit_matrices(seed):
    model, rng = random_model(30 + seed, n_links=12)
    Q = np.array([random_state(model, rng)[0] for _ in range(3)])
    M = dynamics.mass_matrix(model, Q)
    Minv = dynamics.inverse_mass_matrix(model, Q)
    for k in range(3):
        np.testing.assert_allclose(Minv[k] @ M[k], np.eye(model.nv), rtol=0, atol=1e-9 * np.linalg.cond(M[k]) * 1e-6)
        np.testing.assert_array_equal(Minv[k], Minv[k].T)
    f = model.frame_names[-1]
    for ref in REFS:
        for rows in (None, slice(0, 3), [1, 4]):
            J = dynamics.frame_jacobian(model, Q, f, reference=ref)
            r = np.arange(6)[rows if rows is not None else slice(None)]
            A = J[:, r] @ np.linalg.inv(M) @ J[:, r].transpose(0, 2, 1)
            if np.linalg.cond(A).max() > 1e6:  # a random tree whose last frame cannot move along these rows
                continue
            Lam = dynamics.operational_space_inertia(model, Q, f, reference=ref, rows=rows)
            ref_L = np.linalg.inv(A)
            np.testing.assert_allclose(Lam, ref_L, rtol=0, atol=1e-8 * np.abs(ref_L).max())


def test_long_chain_inverse_mass_matrix():
    from robots import chain_urdf

    model = dynamics.load_urdf(chain_urdf(60))
    q = np.random.default_rng(3).uniform(-1, 1, model.nv)
    M = dynamics.mass_matrix(model, q)
    Minv = dynamics.inverse_mass_matrix(model, q)
    assert np.abs(Minv @ M - np.eye(model.nv)).max() < 1e-12 * np.linalg.cond(M)


def test_batches_equal_single_calls_on_talos():
    model = dynamics.load_urdf(erd("talos_data/robots/talos_full_v2.urdf"), floating_base=True)
    rng = np.random.default_rng(5)
    Q, V, A = (np.array(x) for x in zip(*(random_state(model, rng) for _ in range(200))))
    f = "gripper_left_base_link"

    def everything(q, v, a):
        return {
            "fk": dynamics.forward_kinematics(model, q),
            "placement": dynamics.frame_placement(model, q, f),
            "J": dynamics.frame_jacobian(model, q, f, reference="local", point=[0.1, 0, 0]),
            "vel": dynamics.frame_velocity(model, q, v, f),
            "acc": dynamics.frame_acceleration(model, q, v, a, f, classical=False),
            "bias": dynamics.frame_bias_acceleration(model, q, v, f),
            "com": dynamics.center_of_mass(model, q),
            "vcom": dynamics.center_of_mass_velocity(model, q, v),
            "Jcom": dynamics.com_jacobian(model, q),
            "Minv": dynamics.inverse_mass_matrix(model, q),
            "Lambda": dynamics.operational_space_inertia(model, q, f, rows=slice(0, 3)),
        }

    batched = everything(Q, V, A)
    for k in (0, 99, 199):
        for name, x in everything(Q[k], V[k], A[k]).items():
            assert x.shape == batched[name].shape[1:], name
            np.testing.assert_array_equal(x, batched[name][k], err_msg=name)
    # one state against many velocities: q is broadcast
    vel = dynamics.frame_velocity(model, Q[0], V, f)
    np.testing.assert_array_equal(vel[7], dynamics.frame_velocity(model, Q[0], V[7], f))
