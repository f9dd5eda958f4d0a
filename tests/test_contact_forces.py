"""The compliant contact law (dynamics.contact.forces) on hand-made contact lists: the normal force and the
friction against their closed forms, the body wrenches against the RNEA (J^T f_ext), the contact power against
v . J^T f, and the material rules against Drake's formulas."""

import math

import numpy as np
import pytest

import dynamics
from dynamics.contact.config import Material
from dynamics.contact.forces import (D_ELASTIC, D_FN, D_FT, D_SLIP, K_DISS, K_MU_D, K_MU_S, K_STIFF, K_VS, NMAT,
                                     contact_wrenches)
from robots import random_state, random_urdf

MAT = np.array([1e4, 2.0, 0.8, 0.5, 1e-2])  # k, d, mu_s, mu_d, v_s


@pytest.fixture(scope="module")
def floating():
    rng = np.random.default_rng(7)
    return dynamics.load_urdf(random_urdf(rng, 5, floating_joint=True))


def _evaluate(model, q, v, pair_body, point, normal, depth, mat):
    return contact_wrenches(model, q, v, pair_body, point, normal, depth, mat)


def test_wrenches_are_the_rnea_external_forces_and_power_is_v_dot_tau(floating):
    """J^T f_ext read off the RNEA (ID(q, v, 0) - ID(q, v, 0, f_ext)) equals the backward pass's generalised force,
    and the contact power sum F . v_rel equals v . tau_c (bodies against bodies and against the world)."""
    model, rng = floating, np.random.default_rng(1)
    nb = model.tree.parents.shape[0]
    for _ in range(3):
        q, v, _ = random_state(model, rng)
        K = 7
        pair_body = np.array([[rng.integers(0, nb), rng.integers(-1, nb)] for _ in range(K)], np.int64)
        normal = rng.normal(size=(K, 3))
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        f_ext, tau, power, _ = _evaluate(model, q, v, pair_body, rng.normal(size=(K, 3)), normal,
                                         rng.uniform(1e-4, 1e-2, K), np.tile(MAT, (K, 1)))
        a, g0 = np.zeros(model.nv), np.zeros(3)
        jtf = (dynamics.inverse_dynamics(model, q, v, a, gravity=g0)
               - dynamics.inverse_dynamics(model, q, v, a, gravity=g0, f_ext=f_ext))
        scale = np.abs(tau).max()
        assert np.abs(jtf - tau).max() <= 1e-12 * scale
        assert abs(power - v @ tau) <= 1e-12 * max(abs(power), np.abs(v).max() * scale)


def _single(vrel, depth=2e-3, normal=(0.0, 0.0, 1.0), mat=MAT):
    """One contact between a body at rest and the world, with the body's point velocity v_rel: a model of one
    free body whose origin sits at the contact point, moving with v_rel."""
    model = dynamics.load_urdf(random_urdf(np.random.default_rng(3), 1, floating_joint=True))
    q = np.zeros(model.nq)
    q[6] = 1.0
    v = np.zeros(model.nv)
    v[:3] = vrel  # free joint: linear velocity of the origin (body = world axes here), then angular
    f_ext, tau, power, detail = _evaluate(model, q, v, np.array([[0, -1]], np.int64), np.zeros((1, 3)),
                                          np.array([normal], float), np.array([depth]), mat[None, :])
    return f_ext[0], detail[0], power


def _mu(s, mu_s, mu_d):  # the docstring's curve, written again here
    if s < 1:
        return mu_s * s * (2 - s)
    if s < 3:
        x = (s - 1) / 2
        return mu_s - (mu_s - mu_d) * (10 * x**3 - 15 * x**4 + 6 * x**5)
    return mu_d


@pytest.mark.parametrize("vn", [-0.3, -0.01, 0.0, 0.02, 0.4, 1.0])
@pytest.mark.parametrize("slip", [0.0, 3e-3, 1.5e-2, 2.5e-2, 0.3])
def test_normal_force_and_friction_closed_form(vn, slip):
    """f_n = k x (1 + d xdot)_+ (xdot = -v_n) and |f_t| = mu(|v_t| / v_s) f_n against the slip."""
    k, d, mu_s, mu_d, vs = MAT
    x = 2e-3
    vrel = np.array([slip * 0.6, -slip * 0.8, vn])
    f, det, power = _single(vrel, x)
    fn = k * x * max(0.0, 1 - d * vn)
    assert det[D_FN] == pytest.approx(fn, rel=1e-14, abs=1e-12)
    assert f[2] == pytest.approx(fn, rel=1e-14, abs=1e-12)  # never negative: no pull
    ft = np.array(f[:2])
    want = _mu(slip / vs, mu_s, mu_d) * fn
    assert np.linalg.norm(ft) == pytest.approx(want, rel=1e-12, abs=1e-12)
    if want > 0:
        assert np.dot(ft, vrel[:2]) < 0 and abs(ft[0] * vrel[1] - ft[1] * vrel[0]) < 1e-12 * want
    assert np.allclose(det[D_SLIP:D_SLIP + 3], [vrel[0], vrel[1], 0.0], atol=1e-15)
    assert det[D_ELASTIC] == pytest.approx(0.5 * k * x * x, rel=1e-14)
    assert power == pytest.approx(f[:3] @ vrel, rel=1e-12, abs=1e-15)


def test_friction_is_continuous_and_stiction_is_viscous():
    """mu(s) is continuous at s = 1 and 3, and below v_s the friction is ~2 mu_s f_n / v_s times the slip."""
    k, d, mu_s, mu_d, vs = MAT
    for s in (1.0, 3.0):
        lo = np.linalg.norm(_single(np.array([s * vs * (1 - 1e-9), 0, 0]))[0][:2])
        hi = np.linalg.norm(_single(np.array([s * vs * (1 + 1e-9), 0, 0]))[0][:2])
        assert abs(lo - hi) < 1e-6 * hi
    tiny = 1e-9
    f = _single(np.array([tiny, 0, 0]))[0]
    fn = k * 2e-3
    assert -f[0] == pytest.approx(2 * mu_s * fn / vs * tiny, rel=1e-6)


def test_tilted_normal():
    """The law in the contact frame: an inclined normal gives the same magnitudes."""
    n = np.array([0.3, -0.2, 0.9])
    n /= np.linalg.norm(n)
    t = np.cross(n, [1.0, 0, 0])
    t /= np.linalg.norm(t)
    vrel = -0.05 * n + 0.04 * t  # s = 4: the dynamic coefficient
    f, det, _ = _single(vrel, 1e-3, n)
    k, d, mu_s, mu_d, vs = MAT
    fn = k * 1e-3 * (1 + d * 0.05)
    assert f[:3] @ n == pytest.approx(fn, rel=1e-12)
    assert f[:3] @ t == pytest.approx(-mu_d * fn, rel=1e-12)


def test_material_defaults_are_drakes_estimate():
    """Two default geometries combine to Drake's k = m g / delta and d = sqrt(delta / g) / delta."""
    from dynamics.contact.config import combine
    m, g, delta = 30.0, 9.81, 2e-3
    mat = Material(penetration_allowance=delta)
    row = combine(mat.defaults(m, g), mat.defaults(m, g), mat, mat)
    assert row[K_STIFF] == pytest.approx(m * g / delta, rel=1e-15)
    assert row[K_DISS] == pytest.approx(math.sqrt(delta / g) / delta, rel=1e-15)
    assert row[K_MU_S] == row[K_MU_D] == 1.0
    soft = Material(stiffness=1e3, dissipation=5.0, mu_static=0.4, mu_dynamic=0.2, stiction_velocity=1e-2)
    hard = Material(stiffness=4e3, dissipation=1.0, mu_static=0.8, mu_dynamic=0.6)
    row = combine(soft.defaults(m, g), hard.defaults(m, g), soft, hard)
    assert row[K_STIFF] == pytest.approx(800.0)
    assert row[K_DISS] == pytest.approx((4e3 * 5.0 + 1e3 * 1.0) / 5e3)
    assert row[K_MU_S] == pytest.approx(2 * 0.4 * 0.8 / 1.2) and row[K_MU_D] == pytest.approx(2 * 0.2 * 0.6 / 0.8)
    assert row[K_VS] == 1e-2 and NMAT == 5


@pytest.mark.parametrize("kwargs, field", [
    (dict(stiffness=-1.0), "Material.stiffness"), (dict(stiffness=float("nan")), "Material.stiffness"),
    (dict(dissipation=-0.1), "Material.dissipation"), (dict(mu_static=-0.2), "Material.mu_static"),
    (dict(mu_static=0.5, mu_dynamic=0.7), "Material.mu_dynamic"), (dict(stiction_velocity=0.0),
                                                                     "Material.stiction_velocity"),
    (dict(penetration_allowance="1mm"), "Material.penetration_allowance"), (dict(mu_static=True), "Material.mu_static"),
])
def test_material_refuses_bad_values(kwargs, field):
    with pytest.raises(dynamics.InputError, match=field.replace(".", r"\.")):
        Material(**kwargs)
