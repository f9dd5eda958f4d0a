"""Textbook robots against their closed forms (issue 2, section 4).

Each robot in robots/ is loaded with `dynamics.load_urdf` and its inverse dynamics, mass matrix,
gravity torques, bias forces and forward dynamics are compared, at random states, with closed forms
derived by hand (Lagrange: M(q) qdd + C(q, qd) qd + g(q) = tau).  The closed forms use the numbers
written in the URDF headers and in the issue, typed here again on purpose: nothing is read back from
the loaded model, so a wrong parameter in a URDF, or a loader that drops one, fails these tests
(`test_perturbed_parameter_is_caught` proves that the tolerance is tight enough to notice).

Planar robots (2R, RP, 3R) move in the world x-z plane: their base is rotated by +90 deg about world
x, so plane x = world x and plane y = world z.  With a world gravity vector (gx, gy, gz) the
potential energy is V = -sum_k m_k (gx x_k + gz z_k) over the centres of mass (x_k, z_k); gy is
along the joint axes and does no work.  With the default gravity (0, 0, -9.81) the gravity
torques below reduce to the textbook's "g cos q" forms.

The PUMA 560 has no short closed form; it is checked (a) against Pinocchio loaded from the same
URDF, (b) against an independent model written here straight from the DH table (Spong's
M = sum m Jv^T Jv + Jw^T R I R^T Jw and g = -sum m Jv^T g), which also validates the DH-to-URDF
conversion, (c) by hand statics at qz = 0, and (d) against values printed by Corke's Robotics
Toolbox (its unit tests) at its nominal configuration qn.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

import dynamics

ROBOTS = Path(__file__).resolve().parent.parent / "robots"
G0 = 9.81
DEFAULT_GRAVITY = np.array([0.0, 0.0, -G0])
RTOL = 1e-10
N_STATES = 6


def rel_err(actual, expected) -> float:
    """Largest absolute difference relative to the largest entry of the expected array."""
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, (actual.shape, expected.shape)
    scale = max(float(np.max(np.abs(expected))), 1e-300)
    return float(np.max(np.abs(actual - expected))) / scale


def assert_close(actual, expected, what: str, rtol: float = RTOL) -> None:
    err = rel_err(actual, expected)
    assert err <= rtol, f"{what}: relative error {err:.3e} > {rtol:.0e}"


def christoffel_cv(dM: Callable, q, v) -> np.ndarray:
    """C(q, v) v from the partial derivatives of M: (C v)_i = sum_jk (dM_ij/dq_k - 1/2 dM_jk/dq_i) v_j v_k.

    `dM(q)` returns the array dM[k] = dM/dq_k of shape (n, n, n).
    """
    D = dM(q)
    return np.einsum("kij,j,k->i", D, v, v) - 0.5 * np.einsum("ijk,j,k->i", D, v, v)


# ---------------------------------------------------------------------------------------------
# Closed forms.  Each takes one state; gvec is the world gravity vector.
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ClosedForm:
    urdf: str
    joint_names: tuple[str, ...]
    M: Callable  # M(q) -> (n, n)
    Cv: Callable  # Cv(q, v) -> (n,)   Coriolis and centrifugal torques C(q, v) v
    g: Callable  # g(q, gvec) -> (n,) gravity torques dV/dq
    sample_q: Callable  # sample_q(rng) -> (n,)


# Pendulum (robots/pendulum.urdf): point mass m at distance l, q from the horizontal.
#   x = l cos q, z = l sin q;  tau = m l^2 qdd + m g l cos q.
PEND_M, PEND_L = 2.0, 0.75


def pendulum_M(q):
    return np.array([[PEND_M * PEND_L**2]])


def pendulum_Cv(q, v):
    return np.zeros(1)


def pendulum_g(q, gvec):
    gx, gz = gvec[0], gvec[2]
    # dV/dq with V = -m (gx x + gz z); = m g l cos q for gvec = (0, 0, -g).
    return np.array([-PEND_M * PEND_L * (-gx * np.sin(q[0]) + gz * np.cos(q[0]))])


# Planar 2R arm (robots/planar_2r.urdf), the numbers.
R2_M1 = R2_M2 = 12.456
R2_L1 = 1.0
R2_LC1, R2_LC2 = 0.773, 0.583
R2_I1 = R2_I2 = 1.042


def planar_2r_M(q):
    m1, m2, l1, lc1, lc2, I1, I2 = R2_M1, R2_M2, R2_L1, R2_LC1, R2_LC2, R2_I1, R2_I2
    c2 = np.cos(q[1])
    m11 = m1 * lc1**2 + m2 * (l1**2 + lc2**2 + 2 * l1 * lc2 * c2) + I1 + I2
    m12 = m2 * (lc2**2 + l1 * lc2 * c2) + I2
    m22 = m2 * lc2**2 + I2
    return np.array([[m11, m12], [m12, m22]])


def planar_2r_h(q):
    return -R2_M2 * R2_L1 * R2_LC2 * np.sin(q[1])


def planar_2r_Cv(q, v):
    h = planar_2r_h(q)
    return np.array([h * (2 * v[0] * v[1] + v[1] ** 2), -h * v[0] ** 2])


def planar_2r_C(q, v):
    """The Christoffel-symbol Coriolis matrix (Spong): dM/dt - 2C is skew-symmetric."""
    h = planar_2r_h(q)
    return np.array([[h * v[1], h * (v[0] + v[1])], [-h * v[0], 0.0]])


def planar_2r_Mdot(q, v):
    h = planar_2r_h(q)
    return np.array([[2 * h * v[1], h * v[1]], [h * v[1], 0.0]])


def planar_2r_g(q, gvec):
    gx, gz = gvec[0], gvec[2]
    q1, q12 = q[0], q[0] + q[1]
    # d/dq of (gx x + gz z) for a point at radius r on a link at absolute angle t: r (-gx sin t + gz cos t)
    w1 = -gx * np.sin(q1) + gz * np.cos(q1)
    w12 = -gx * np.sin(q12) + gz * np.cos(q12)
    # For gvec = (0, 0, -g): [(m1 lc1 + m2 l1) g c1 + m2 lc2 g c12, m2 lc2 g c12].
    return -np.array(
        [(R2_M1 * R2_LC1 + R2_M2 * R2_L1) * w1 + R2_M2 * R2_LC2 * w12, R2_M2 * R2_LC2 * w12]
    )


def planar_2r_V(q, gvec):
    gx, gz = gvec[0], gvec[2]
    q1, q12 = q[0], q[0] + q[1]
    x1, z1 = R2_LC1 * np.cos(q1), R2_LC1 * np.sin(q1)
    x2 = R2_L1 * np.cos(q1) + R2_LC2 * np.cos(q12)
    z2 = R2_L1 * np.sin(q1) + R2_LC2 * np.sin(q12)
    return -(R2_M1 * (gx * x1 + gz * z1) + R2_M2 * (gx * x2 + gz * z2))


# RP arm (robots/rp_arm.urdf): q = (q1, d2); d2 = prismatic coordinate = distance from the
# revolute axis to link 2's centre of mass, along link 1.  The issue's closed form.
RP_M1, RP_L1, RP_I1 = 8.0, 0.4, 0.35
RP_M2, RP_I2 = 5.0, 0.25


def rp_arm_M(q):
    d2 = q[1]
    return np.array([[RP_M1 * RP_L1**2 + RP_I1 + RP_M2 * d2**2 + RP_I2, 0.0], [0.0, RP_M2]])


def rp_arm_Cv(q, v):
    d2 = q[1]
    return np.array([2 * RP_M2 * d2 * v[0] * v[1], -RP_M2 * d2 * v[0] ** 2])


def rp_arm_g(q, gvec):
    gx, gz = gvec[0], gvec[2]
    q1, d2 = q
    s1, c1 = np.sin(q1), np.cos(q1)
    # For gvec = (0, 0, -g): [(m1 l1 + m2 d2) g cos q1, m2 g sin q1].
    return -np.array(
        [(RP_M1 * RP_L1 + RP_M2 * d2) * (-gx * s1 + gz * c1), RP_M2 * (gx * c1 + gz * s1)]
    )


# Planar 3R arm (robots/planar_3r.urdf): three uniform 1 m rods.
R3_M = (3.0, 2.4, 1.2)
R3_A = (1.0, 1.0, 1.0)
R3_LC = (0.5, 0.5, 0.5)
R3_I = (0.25, 0.2, 0.1)


def planar_3r_M(q):
    (m1, m2, m3), (a1, a2, _), (lc1, lc2, lc3), (I1, I2, I3) = R3_M, R3_A, R3_LC, R3_I
    c2, c3, c23 = np.cos(q[1]), np.cos(q[2]), np.cos(q[1] + q[2])
    m33 = m3 * lc3**2 + I3
    m23 = m3 * (lc3**2 + a2 * lc3 * c3) + I3
    m13 = m3 * (lc3**2 + a2 * lc3 * c3 + a1 * lc3 * c23) + I3
    m22 = m2 * lc2**2 + I2 + m3 * (a2**2 + lc3**2 + 2 * a2 * lc3 * c3) + I3
    m12 = (
        m2 * (lc2**2 + a1 * lc2 * c2)
        + I2
        + m3 * (a2**2 + lc3**2 + 2 * a2 * lc3 * c3 + a1 * a2 * c2 + a1 * lc3 * c23)
        + I3
    )
    m11 = (
        m1 * lc1**2
        + I1
        + m2 * (a1**2 + lc2**2 + 2 * a1 * lc2 * c2)
        + I2
        + m3 * (a1**2 + a2**2 + lc3**2 + 2 * a1 * a2 * c2 + 2 * a2 * lc3 * c3 + 2 * a1 * lc3 * c23)
        + I3
    )
    return np.array([[m11, m12, m13], [m12, m22, m23], [m13, m23, m33]])


def planar_3r_dM(q):
    """dM/dq_k, k = 1, 2, 3, differentiated by hand from planar_3r_M (M does not depend on q1)."""
    (_, m2, m3), (a1, a2, _), (_, lc2, lc3) = R3_M, R3_A, R3_LC
    s2, s3, s23 = np.sin(q[1]), np.sin(q[2]), np.sin(q[1] + q[2])
    d2 = np.zeros((3, 3))  # d/dq2: c2 -> -s2, c23 -> -s23
    d2[0, 0] = -2 * m2 * a1 * lc2 * s2 - m3 * (2 * a1 * a2 * s2 + 2 * a1 * lc3 * s23)
    d2[0, 1] = d2[1, 0] = -m2 * a1 * lc2 * s2 - m3 * (a1 * a2 * s2 + a1 * lc3 * s23)
    d2[0, 2] = d2[2, 0] = -m3 * a1 * lc3 * s23
    d3 = np.zeros((3, 3))  # d/dq3: c3 -> -s3, c23 -> -s23
    d3[0, 0] = -m3 * (2 * a2 * lc3 * s3 + 2 * a1 * lc3 * s23)
    d3[0, 1] = d3[1, 0] = -m3 * (2 * a2 * lc3 * s3 + a1 * lc3 * s23)
    d3[0, 2] = d3[2, 0] = -m3 * (a2 * lc3 * s3 + a1 * lc3 * s23)
    d3[1, 1] = -2 * m3 * a2 * lc3 * s3
    d3[1, 2] = d3[2, 1] = -m3 * a2 * lc3 * s3
    return np.stack([np.zeros((3, 3)), d2, d3])


def planar_3r_Cv(q, v):
    return christoffel_cv(planar_3r_dM, q, v)


def planar_3r_g(q, gvec):
    gx, gz = gvec[0], gvec[2]
    (m1, m2, m3), (a1, a2, _), (lc1, lc2, lc3) = R3_M, R3_A, R3_LC
    t1, t12, t123 = q[0], q[0] + q[1], q[0] + q[1] + q[2]

    def w(t):
        return -gx * np.sin(t) + gz * np.cos(t)

    # For gvec = (0, 0, -g): g1 = g[(m1 lc1 + (m2 + m3) a1) c1 + (m2 lc2 + m3 a2) c12 + m3 lc3 c123] ...
    g3 = m3 * lc3 * w(t123)
    g2 = (m2 * lc2 + m3 * a2) * w(t12) + g3
    g1 = (m1 * lc1 + (m2 + m3) * a1) * w(t1) + g2
    return -np.array([g1, g2, g3])


def _angles(n):
    return lambda rng: rng.uniform(-np.pi, np.pi, n)


CLOSED_FORMS = {
    "pendulum": ClosedForm(
        "pendulum.urdf",
        ("hinge",),
        pendulum_M,
        pendulum_Cv,
        pendulum_g,
        # continuous joint: one angle, any value (no wrapping to (-pi, pi])
        lambda rng: rng.uniform(-2 * np.pi, 2 * np.pi, 1),
    ),
    "planar_2r": ClosedForm(
        "planar_2r.urdf", ("joint1", "joint2"), planar_2r_M, planar_2r_Cv, planar_2r_g, _angles(2)
    ),
    "rp_arm": ClosedForm(
        "rp_arm.urdf",
        ("joint1", "joint2"),
        rp_arm_M,
        rp_arm_Cv,
        rp_arm_g,
        # d2 on both sides of the revolute axis, including outside the nominal stroke
        lambda rng: np.array([rng.uniform(-np.pi, np.pi), rng.uniform(-0.5, 1.8)]),
    ),
    "planar_3r": ClosedForm(
        "planar_3r.urdf",
        ("joint1", "joint2", "joint3"),
        planar_3r_M,
        planar_3r_Cv,
        planar_3r_g,
        _angles(3),
    ),
}
PLANAR = sorted(CLOSED_FORMS)

_MODELS: dict[str, dynamics.Model] = {}


def load(name: str):
    if name not in _MODELS:
        _MODELS[name] = dynamics.load_urdf(str(ROBOTS / name))
    return _MODELS[name]


def states(cf: ClosedForm, seed: int):
    """N_STATES random (q, v, a, tau) with the given seed, stacked as batches."""
    rng = np.random.default_rng(seed)
    q = np.stack([cf.sample_q(rng) for _ in range(N_STATES)])
    n = q.shape[1]
    v = rng.uniform(-3.0, 3.0, (N_STATES, n))
    a = rng.uniform(-5.0, 5.0, (N_STATES, n))
    tau = rng.uniform(-50.0, 50.0, (N_STATES, n))
    return q, v, a, tau


def expected(cf: ClosedForm, quantity: str, q, v, a, tau, gvec):
    """The closed form of `quantity` for one state."""
    M, Cv, g = cf.M(q), cf.Cv(q, v), cf.g(q, gvec)
    if quantity == "inverse_dynamics":
        return M @ a + Cv + g
    if quantity == "mass_matrix":
        return M
    if quantity == "gravity_torques":
        return g
    if quantity == "bias_forces":
        return Cv + g
    if quantity == "forward_dynamics":
        return np.linalg.solve(M, tau - Cv - g)
    raise AssertionError(quantity)


def compute(model, quantity: str, q, v, a, tau, gravity=None):
    """The library's value of `quantity`; q, v, a, tau are one state or a batch."""
    kw = {} if gravity is None else {"gravity": gravity}
    if quantity == "inverse_dynamics":
        return dynamics.inverse_dynamics(model, q, v, a, **kw)
    if quantity == "mass_matrix":
        return dynamics.mass_matrix(model, q)
    if quantity == "gravity_torques":
        return dynamics.gravity_torques(model, q, **kw)
    if quantity == "bias_forces":
        return dynamics.bias_forces(model, q, v, **kw)
    if quantity == "forward_dynamics":
        return dynamics.forward_dynamics(model, q, v, tau, **kw)
    raise AssertionError(quantity)


QUANTITIES = ["inverse_dynamics", "mass_matrix", "gravity_torques", "bias_forces", "forward_dynamics"]


# ---------------------------------------------------------------------------------------------
# Pendulum, 2R, RP, 3R against their closed forms
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", PLANAR)
def test_model_structure(name):
    cf = CLOSED_FORMS[name]
    model = load(cf.urdf)
    n = len(cf.joint_names)
    assert model.joint_names == cf.joint_names
    assert (model.nq, model.nv, model.floating_base) == (n, n, False)


@pytest.mark.parametrize("quantity", QUANTITIES)
@pytest.mark.parametrize("name", PLANAR)
def test_closed_form_single_state(name, quantity):
    cf = CLOSED_FORMS[name]
    model = load(cf.urdf)
    for q, v, a, tau in zip(*states(cf, seed=1)):
        ref = expected(cf, quantity, q, v, a, tau, DEFAULT_GRAVITY)
        got = compute(model, quantity, q, v, a, tau)
        assert_close(got, ref, f"{name} {quantity} at q={q}")


@pytest.mark.parametrize("quantity", QUANTITIES)
@pytest.mark.parametrize("name", PLANAR)
def test_closed_form_batch(name, quantity):
    """The same comparison through the batched entry point, with a non-default gravity vector."""
    cf = CLOSED_FORMS[name]
    model = load(cf.urdf)
    gvec = np.array([1.3, -2.0, -3.7])  # gy is along the joint axes: it must do nothing
    q, v, a, tau = states(cf, seed=2)
    got = compute(model, quantity, q, v, a, tau, gravity=gvec)
    ref = np.stack([expected(cf, quantity, *s, gvec) for s in zip(q, v, a, tau)])
    assert got.shape == ref.shape
    assert_close(got, ref, f"{name} {quantity} (batch, gravity={gvec})")


def test_pendulum_closed_form_literal():
    """The issue's formula written out once more, at hand-picked angles: tau = m l^2 qdd + m g l cos q."""
    model = load("pendulum.urdf")
    m, l = 2.0, 0.75
    for q, qdd in [(0.0, 0.0), (np.pi / 2, 1.0), (-np.pi / 3, -2.5), (7.0, 4.0)]:
        tau = dynamics.inverse_dynamics(model, np.array([q]), np.array([0.9]), np.array([qdd]))
        assert_close(tau, np.array([m * l**2 * qdd + m * G0 * l * np.cos(q)]), f"pendulum q={q}")
    # horizontal pendulum at rest: the torque that holds it is exactly m g l
    assert_close(dynamics.gravity_torques(model, np.zeros(1)), np.array([m * G0 * l]), "m g l")


def test_pendulum_external_force():
    """f_ext: a force F along the body z axis applied at the point mass (body frame, torque about
    the hinge = r x F) does virtual work l F per unit qd, so tau = m l^2 qdd + m g l cos q - l F."""
    model = load("pendulum.urdf")
    m, l, F = 2.0, 0.75, 3.5
    r = np.array([l, 0.0, 0.0])
    force = np.array([0.0, 0.0, F])
    f_ext = np.concatenate([force, np.cross(r, force)])[None, :]
    q, v, a = np.array([0.4]), np.array([1.1]), np.array([-0.7])
    tau = dynamics.inverse_dynamics(model, q, v, a, f_ext=f_ext)
    assert_close(tau, np.array([m * l**2 * a[0] + m * G0 * l * np.cos(q[0]) - l * F]), "pendulum f_ext")
    acc = dynamics.forward_dynamics(model, q, v, np.zeros(1), f_ext=f_ext)
    assert_close(acc, np.array([(l * F - m * G0 * l * np.cos(q[0])) / (m * l**2)]), "pendulum fd f_ext")


def test_rp_arm_literal():
    """The issue's RP formula with its symbols, at a state chosen by hand (d2 = 0.8)."""
    model = load("rp_arm.urdf")
    m1, l1, I1, m2, I2, g = 8.0, 0.4, 0.35, 5.0, 0.25, G0
    q1, d2, qd1, dd2 = 0.3, 0.8, 1.7, -0.6
    M = np.array([[m1 * l1**2 + I1 + m2 * d2**2 + I2, 0], [0, m2]])
    C = np.array([2 * m2 * d2 * qd1 * dd2, -m2 * d2 * qd1**2])
    G = np.array([(m1 * l1 + m2 * d2) * g * np.cos(q1), m2 * g * np.sin(q1)])
    q, v = np.array([q1, d2]), np.array([qd1, dd2])
    assert_close(dynamics.mass_matrix(model, q), M, "rp M")
    assert_close(dynamics.bias_forces(model, q, v), C + G, "rp C qd + g")
    assert_close(dynamics.gravity_torques(model, q), G, "rp g")


def test_planar_2r_coriolis_matrix_and_energy():
    """C v equals the closed form, dM/dt - 2C is skew-symmetric with dM/dt in closed form,
    T = 1/2 v^T M v, and potential energy differences match V = -sum m g.c (any constant offset)."""
    model = load("planar_2r.urdf")
    rng = np.random.default_rng(3)
    q0 = rng.uniform(-np.pi, np.pi, 2)
    for _ in range(N_STATES):
        q, v = rng.uniform(-np.pi, np.pi, 2), rng.uniform(-3, 3, 2)
        C = dynamics.coriolis_matrix(model, q, v)
        assert_close(C @ v, planar_2r_Cv(q, v), "2R C v")
        N = planar_2r_Mdot(q, v) - 2 * C
        assert np.max(np.abs(N + N.T)) <= RTOL * np.max(np.abs(planar_2r_Mdot(q, v))) + 1e-12
        # the Christoffel C is the textbook's; any valid C gives the same C v
        assert_close(planar_2r_C(q, v) @ v, planar_2r_Cv(q, v), "2R textbook C")
        T = dynamics.kinetic_energy(model, q, v)
        assert_close(T, 0.5 * v @ planar_2r_M(q) @ v, "2R kinetic energy")
        dV = dynamics.potential_energy(model, q) - dynamics.potential_energy(model, q0)
        assert_close(dV, planar_2r_V(q, DEFAULT_GRAVITY) - planar_2r_V(q0, DEFAULT_GRAVITY), "2R dV")


PERTURBATIONS = {
    # robot: (exact text in the URDF, replacement); each changes one number by ~1e-7 relative
    "pendulum": ('<origin xyz="0.75 0 0"', '<origin xyz="0.7500001 0 0"'),
    "planar_2r": ('<origin xyz="0.583 0 0"', '<origin xyz="0.5830001 0 0"'),
    "rp_arm": ('<mass value="5.0"/>', '<mass value="5.0000005"/>'),
    "planar_3r": ('iyy="0.1" iyz="0" izz="0.1"', 'iyy="0.1" iyz="0" izz="0.1000001"'),
}


@pytest.mark.parametrize("name", PLANAR)
def test_perturbed_parameter_is_caught(name):
    """The tests above can fail: a URDF with one parameter off by ~1e-7 relative no longer
    matches the closed form at 1e-10 (so the closed forms are not read back from the model)."""
    cf = CLOSED_FORMS[name]
    old, new = PERTURBATIONS[name]
    text = (ROBOTS / cf.urdf).read_text()
    assert text.count(old) == 1
    model = dynamics.load_urdf(text.replace(old, new))
    q, v, a, tau = states(cf, seed=4)
    worst = 0.0
    for quantity in QUANTITIES:
        got = compute(model, quantity, q, v, a, tau)
        ref = np.stack([expected(cf, quantity, *s, DEFAULT_GRAVITY) for s in zip(q, v, a, tau)])
        worst = max(worst, rel_err(got, ref))
    assert worst > 100 * RTOL, f"{name}: perturbation not detected (worst error {worst:.2e})"


# ---------------------------------------------------------------------------------------------
# PUMA 560
# ---------------------------------------------------------------------------------------------

# The DH table and inertial parameters, typed from the source (see robots/puma560.urdf header):
# Corke & Armstrong-Helouvry 1994 as tabulated in Corke's Robotics Toolbox (mdl_puma560).
PUMA_DH = [  # (d, a, alpha)
    (0.0, 0.0, np.pi / 2),
    (0.0, 0.4318, 0.0),
    (0.15005, 0.0203, -np.pi / 2),
    (0.4318, 0.0, np.pi / 2),
    (0.0, 0.0, -np.pi / 2),
    (0.0, 0.0, 0.0),
]
PUMA_MASS = [0.0, 17.4, 4.8, 0.82, 0.34, 0.09]
PUMA_COM = [  # in DH frame {i}
    (0.0, 0.0, 0.0),
    (-0.3638, 0.006, 0.2275),
    (-0.0203, -0.0141, 0.070),
    (0.0, 0.019, 0.0),
    (0.0, 0.0, 0.0),
    (0.0, 0.0, 0.032),
]
PUMA_I_PUBLISHED = [  # principal moments about the COM, in frame {i} axes, verbatim
    (0.0, 0.35, 0.0),
    (0.13, 0.524, 0.539),
    (0.066, 0.086, 0.0125),
    (1.8e-3, 1.3e-3, 1.8e-3),
    (0.3e-3, 0.4e-3, 0.3e-3),
    (0.15e-3, 0.15e-3, 0.04e-3),
]
# What the URDF must be equivalent to.  Link 1 stays verbatim: its published tensor is not a rigid
# body's, the URDF uses diag(0.175, 0.35, 0.175), but only Iyy (about z0) enters the dynamics, so
# the two must give the same M.  Link 3's published moments violate the triangle inequality; the
# URDF uses their projection onto Iyy = Ixx + Izz (see the URDF header).
PUMA_I = list(PUMA_I_PUBLISHED)
PUMA_I[2] = (0.0685, 0.0835, 0.015)
# Motor armature and gear ratio (Jm, G) from the same toolbox model: only used to compare with the
# toolbox's printed inertia matrix, which includes Jm G^2 on the diagonal.
PUMA_JM = np.array([200e-6, 200e-6, 200e-6, 33e-6, 33e-6, 33e-6])
PUMA_GEAR = np.array([-62.6111, 107.815, -53.7063, 76.0364, 71.923, 76.686])
PUMA_QZ = np.zeros(6)
PUMA_QN = np.array([0.0, np.pi / 4, np.pi, 0.0, np.pi / 4, 0.0])


def puma_dh_reference(q, gvec=DEFAULT_GRAVITY, inertias=PUMA_I):
    """M(q) and g(q) from the DH table (Spong, "Robot Modeling and Control", Dynamics chapter):
    M = sum_k m_k Jv_k^T Jv_k + Jw_k^T R_k I_k R_k^T Jw_k,  g = -sum_k m_k Jv_k^T gvec,
    with standard DH T_{i-1,i} = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i) and joint i about z_{i-1}."""
    n = 6
    T = np.eye(4)
    z, o = [], []  # joint axes z_{i-1} and origins o_{i-1} in the world
    M = np.zeros((n, n))
    g = np.zeros(n)
    for i, (d, a, alpha) in enumerate(PUMA_DH):
        z.append(T[:3, 2].copy())
        o.append(T[:3, 3].copy())
        ct, st, ca, sa = np.cos(q[i]), np.sin(q[i]), np.cos(alpha), np.sin(alpha)
        A = np.array(
            [[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1]]
        )
        T = T @ A
        R = T[:3, :3]
        c = T[:3, 3] + R @ np.array(PUMA_COM[i])
        Jv = np.zeros((3, n))
        Jw = np.zeros((3, n))
        for j in range(i + 1):
            Jv[:, j] = np.cross(z[j], c - o[j])
            Jw[:, j] = z[j]
        Iw = R @ np.diag(inertias[i]) @ R.T
        M += PUMA_MASS[i] * Jv.T @ Jv + Jw.T @ Iw @ Jw
        g -= PUMA_MASS[i] * Jv.T @ gvec
    return M, g


@pytest.fixture(scope="module")
def puma():
    return load("puma560.urdf")


@pytest.fixture(scope="module")
def puma_pin():
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromUrdf(str(ROBOTS / "puma560.urdf"))
    return pin, model, model.createData()


def puma_states(seed):
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(-np.pi, np.pi, (N_STATES, 6)),
        rng.uniform(-3.0, 3.0, (N_STATES, 6)),
        rng.uniform(-5.0, 5.0, (N_STATES, 6)),
        rng.uniform(-20.0, 20.0, (N_STATES, 6)),
    )


def test_puma_structure(puma, puma_pin):
    pin, pmodel, _ = puma_pin
    assert puma.joint_names == tuple(f"joint{i}" for i in range(1, 7))
    assert puma.joint_names == tuple(pmodel.names[1:])
    assert (puma.nq, puma.nv, puma.nbodies) == (6, 6, 6)


@pytest.mark.parametrize("quantity", QUANTITIES)
def test_puma_against_pinocchio(puma, puma_pin, quantity):
    pin, pm, pd = puma_pin
    Q, V, A, TAU = puma_states(seed=5)
    for q, v, a, tau in zip(Q, V, A, TAU):
        ref = {
            "inverse_dynamics": lambda: pin.rnea(pm, pd, q, v, a),
            "mass_matrix": lambda: pin.crba(pm, pd, q),
            "gravity_torques": lambda: pin.computeGeneralizedGravity(pm, pd, q),
            "bias_forces": lambda: pin.nonLinearEffects(pm, pd, q, v),
            "forward_dynamics": lambda: pin.aba(pm, pd, q, v, tau),
        }[quantity]().copy()
        if quantity == "mass_matrix":
            ref = np.triu(ref) + np.triu(ref, 1).T  # Pinocchio fills the upper triangle only
        assert_close(compute(puma, quantity, q, v, a, tau), ref, f"PUMA {quantity} vs Pinocchio")
    batch = compute(puma, quantity, Q, V, A, TAU)
    single = np.stack([compute(puma, quantity, *s) for s in zip(Q, V, A, TAU)])
    assert_close(batch, single, f"PUMA {quantity} batch vs single")


def test_puma_against_dh_model(puma):
    """Mass matrix and gravity against the independent DH-table model at random states."""
    Q, _, _, _ = puma_states(seed=6)
    for q in Q:
        M, g = puma_dh_reference(q)
        assert_close(dynamics.mass_matrix(puma, q), M, "PUMA M vs DH model")
        assert_close(dynamics.gravity_torques(puma, q), g, "PUMA g vs DH model")
    gvec = np.array([0.5, 2.0, -9.0])
    M, g = puma_dh_reference(Q[0], gvec)
    assert_close(dynamics.gravity_torques(puma, Q[0], gravity=gvec), g, "PUMA g(custom gravity)")


def test_puma_gravity_qz_derived(puma):
    """Gravity torques at qz = 0 by statics, by hand.  At qz the upper arm is horizontal along +x,
    the forearm vertical; joint 2 and 3 axes are horizontal (along -y), so each torque is
    g * sum(m_k * horizontal lever arm along x of the COM from the joint axis).
      joint 2 (axis through the origin): link 2 COM x = a2 + r2x = 0.068; link 3 COM x =
        a2 + a3 + r3x = 0.4318; links 4-6 lie on the wrist axis x = a2 + a3 = 0.4521.
      joint 3 (axis at x = a2): link 3 COM lever a3 + r3x = 0; links 4-6 lever a3 = 0.0203.
    Joints 1, 4, 5, 6 hold no gravity torque at qz (vertical axis, or COMs on the axis)."""
    a2, a3, g = 0.4318, 0.0203, G0
    m2, m3, m456 = 17.4, 4.8, 0.82 + 0.34 + 0.09
    tau2 = g * (m2 * (a2 - 0.3638) + m3 * (a2 + a3 - 0.0203) + m456 * (a2 + a3))
    tau3 = g * (m3 * (a3 - 0.0203) + m456 * a3)
    ref = np.array([0.0, tau2, tau3, 0.0, 0.0, 0.0])
    assert_close(dynamics.gravity_torques(puma, PUMA_QZ), ref, "PUMA g(qz) by statics")


def test_puma_published_values(puma):
    """Values printed by Corke's Robotics Toolbox for Python for the same parameters
    (petercorke/robotics-toolbox-python, tests/test_SerialLink.py: test_gravload gives gravload(qn),
    test_inertia gives inertia(qn)), printed to 4 decimals, so the tolerance is 5e-5 plus rounding.
    The toolbox's inertia includes the motor armature Jm G^2 on the diagonal, which a URDF does not
    model, so it is added here, and so is the (exact, DH-model) effect of our link 3 correction.
    (qz is checked by hand in test_puma_gravity_qz_derived.)"""
    tol = 5.1e-5
    g_qn = dynamics.gravity_torques(puma, PUMA_QN)
    np.testing.assert_allclose(g_qn, [0.0, 31.6399, 6.0351, 0.0, 0.0283, 0.0], rtol=0, atol=tol)
    link3_fix = puma_dh_reference(PUMA_QN, inertias=PUMA_I_PUBLISHED)[0] - puma_dh_reference(PUMA_QN)[0]
    M_qn = dynamics.mass_matrix(puma, PUMA_QN) + np.diag(PUMA_JM * PUMA_GEAR**2) + link3_fix
    M_ref = np.array(
        [
            [3.6594, -0.4044, 0.1006, -0.0025, 0.0000, -0.0000],
            [-0.4044, 4.4137, 0.3509, 0.0000, 0.0024, 0.0000],
            [0.1006, 0.3509, 0.9378, 0.0000, 0.0015, 0.0000],
            [-0.0025, 0.0000, 0.0000, 0.1925, 0.0000, 0.0000],
            [0.0000, 0.0024, 0.0015, 0.0000, 0.1713, 0.0000],
            [-0.0000, 0.0000, 0.0000, 0.0000, 0.0000, 0.1941],
        ]
    )
    np.testing.assert_allclose(M_qn, M_ref, rtol=0, atol=tol)


def test_puma_perturbed_dh_is_caught():
    """A URDF with d3 off by 10 micrometres no longer matches the DH model at 1e-10."""
    text = (ROBOTS / "puma560.urdf").read_text()
    old, new = '<origin xyz="0.0203 0 0.15005"', '<origin xyz="0.0203 0 0.15006"'
    assert text.count(old) == 1
    model = dynamics.load_urdf(text.replace(old, new))
    Q, _, _, _ = puma_states(seed=7)
    worst = 0.0
    for q in Q:
        M, g = puma_dh_reference(q)
        worst = max(worst, rel_err(dynamics.mass_matrix(model, q), M))
        worst = max(worst, rel_err(dynamics.gravity_torques(model, q), g))
    assert worst > 100 * RTOL, f"perturbation not detected (worst error {worst:.2e})"
