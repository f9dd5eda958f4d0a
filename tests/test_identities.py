"""Identities that must hold on any tree, checked on random trees and on extreme robots."""

import numpy as np
import pytest

import dynamics
from robots import chain_urdf, random_state, random_urdf


def random_model(seed, floating=False, **kw):
    rng = np.random.default_rng(seed)
    return dynamics.load_urdf(random_urdf(rng, n_links=int(rng.integers(3, 12)), floating_joint=floating, **kw)), rng


@pytest.mark.parametrize("seed", range(10))
def test_mass_matrix_equals_rnea_columns_and_is_spd(seed):
    model, rng = random_model(seed, floating=seed % 2 == 1)
    q, v, _ = random_state(model, rng)
    M = dynamics.mass_matrix(model, q)
    # column k of M is RNEA(q, 0, e_k) - g(q)
    g = dynamics.gravity_torques(model, q)
    cols = dynamics.inverse_dynamics(model, np.tile(q, (model.nv, 1)), np.zeros((model.nv, model.nv)),
                                     np.eye(model.nv)) - g
    np.testing.assert_allclose(M, cols.T, rtol=0, atol=1e-12 * np.abs(M).max())
    np.testing.assert_array_equal(M, M.T)
    assert np.linalg.eigvalsh(M).min() > 0


@pytest.mark.parametrize("seed", range(10))
def test_aba_inverts_rnea(seed):
    model, rng = random_model(seed, floating=seed % 2 == 0)
    Q, V, A = (np.array(x) for x in zip(*(random_state(model, rng, scale=3.0) for _ in range(50))))
    tau = dynamics.inverse_dynamics(model, Q, V, A)
    np.testing.assert_allclose(dynamics.forward_dynamics(model, Q, V, tau), A, rtol=0, atol=1e-9 * np.abs(A).max())
    # and ABA agrees with solving the CRBA system
    M = dynamics.mass_matrix(model, Q)
    b = dynamics.bias_forces(model, Q, V)
    np.testing.assert_allclose(np.linalg.solve(M, (tau - b)[..., None])[..., 0], A, atol=1e-9 * np.abs(A).max())


@pytest.mark.parametrize("seed", range(8))
def test_coriolis_skew_and_consistent(seed):
    model, rng = random_model(seed)
    q, v, _ = random_state(model, rng)
    C = dynamics.coriolis_matrix(model, q, v)
    np.testing.assert_allclose(C @ v + dynamics.gravity_torques(model, q), dynamics.bias_forces(model, q, v),
                               atol=1e-11 * max(1, np.abs(C @ v).max()))
    h = 1e-5
    dM = (dynamics.mass_matrix(model, q + h * v) - dynamics.mass_matrix(model, q - h * v)) / (2 * h)
    N = dM - 2 * C
    assert np.abs(N + N.T).max() < 1e-7 * max(1.0, np.abs(dM).max())


@pytest.mark.parametrize("seed", range(8))
def test_power_balance(seed):
    """d(T + U)/dt = v . tau along the motion that tau produces."""
    model, rng = random_model(seed)
    q, v, a = random_state(model, rng)
    tau = dynamics.inverse_dynamics(model, q, v, a)

    def energy(t):
        qt, vt = q + t * v + 0.5 * t * t * a, v + t * a
        return dynamics.kinetic_energy(model, qt, vt) + dynamics.potential_energy(model, qt)

    h = 1e-5
    dE = (energy(h) - energy(-h)) / (2 * h)
    assert abs(dE - v @ tau) < 1e-6 * max(1.0, abs(v @ tau), dynamics.kinetic_energy(model, q, v))


def test_kinetic_energy_is_quadratic_form():
    model, rng = random_model(3, floating=True)
    q, v, _ = random_state(model, rng)
    assert dynamics.kinetic_energy(model, q, v) == pytest.approx(0.5 * v @ dynamics.mass_matrix(model, q) @ v, rel=1e-12)


def test_gravity_is_gradient_of_potential():
    model, rng = random_model(4)
    q, _, _ = random_state(model, rng)
    h = 1e-6
    grad = [(dynamics.potential_energy(model, q + h * e) - dynamics.potential_energy(model, q - h * e)) / (2 * h)
            for e in np.eye(model.nq)]
    np.testing.assert_allclose(grad, dynamics.gravity_torques(model, q), atol=1e-6)


# -- extremes -----------------------------------------------------------------------------------------

def test_1000_link_chain_is_finite_and_aba_matches_crba_within_conditioning():
    model = dynamics.load_urdf(chain_urdf(1000, length=0.01, mass=0.01, inertia=1e-7))
    rng = np.random.default_rng(0)
    q = rng.uniform(-0.3, 0.3, model.nq)
    v = rng.normal(size=model.nv)
    tau = rng.normal(size=model.nv) * 1e-3
    a = dynamics.forward_dynamics(model, q, v, tau)
    M = dynamics.mass_matrix(model, q)
    b = dynamics.bias_forces(model, q, v)
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(M))
    ref = np.linalg.solve(M, tau - b)
    cond = np.linalg.cond(M)
    assert np.linalg.norm(a - ref) / np.linalg.norm(ref) < max(1e-10, 10 * cond * np.finfo(float).eps)
    # and the round trip through RNEA holds to the same accuracy
    np.testing.assert_allclose(dynamics.inverse_dynamics(model, q, v, a), tau, atol=1e-8 * np.abs(b).max())


@pytest.mark.parametrize("mass_range", [(1e-6, 1e-6), (1e-6, 1e3), (1e3, 1e3)])
def test_extreme_mass_ratios(mass_range):
    rng = np.random.default_rng(11)
    text = random_urdf(rng, n_links=8, mass_range=mass_range, types=("revolute", "prismatic"))
    model = dynamics.load_urdf(text)
    q, v, a = random_state(model, rng)
    tau = dynamics.inverse_dynamics(model, q, v, a)
    M = dynamics.mass_matrix(model, q)
    acc = dynamics.forward_dynamics(model, q, v, tau)
    assert np.linalg.norm(acc - a) / np.linalg.norm(a) < max(1e-10, 10 * np.linalg.cond(M) * np.finfo(float).eps)


def test_tiny_inertias_and_fast_spins():
    """1e-9 kg m^2 inertias on a chain spun at 100 rad/s: finite and self-consistent."""
    model = dynamics.load_urdf(chain_urdf(6, length=0.05, mass=1e-3, inertia=1e-9))
    rng = np.random.default_rng(5)
    q = rng.uniform(-np.pi, np.pi, model.nq)
    v = np.full(model.nv, 100.0)
    a = rng.normal(size=model.nv)
    tau = dynamics.inverse_dynamics(model, q, v, a)
    acc = dynamics.forward_dynamics(model, q, v, tau)
    M = dynamics.mass_matrix(model, q)
    assert np.all(np.isfinite(tau))
    # the error scales with the largest term: the centripetal accelerations M^-1 b at 100 rad/s
    scale = max(np.linalg.norm(a), np.linalg.norm(np.linalg.solve(M, dynamics.bias_forces(model, q, v))))
    assert scale > 1e3
    assert np.linalg.norm(acc - a) / scale < max(1e-10, 10 * np.linalg.cond(M) * np.finfo(float).eps)
    # a single spinning link: centripetal load only, tau = 0 at constant speed about a vertical axis
    spin = dynamics.load_urdf(chain_urdf(1, axis="0 0 1"))
    assert np.abs(dynamics.inverse_dynamics(spin, [0.3], [100.0], [0.0])).max() < 1e-9
