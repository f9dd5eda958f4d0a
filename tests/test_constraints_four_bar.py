"""The lectures' planar four-bar (robots/four_bar.urdf, a crank-rocker): constrained accelerations and
multipliers against the closed form

    M qdd = f - Phi_q^T (Phi_q M^-1 Phi_q^T)^-1 {Phi_q M^-1 f + Phi_q_dot qd},   f = tau - C qd - G

with the lectures' M, C, G of the open 2R + 1R tree and their two loop equations; a 10 s motion integrated by
SciPy from our dynamics against SciPy on that formula; drift with and without Baumgarte; assembly.
"""

import os
import re

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import dynamics
from robots import OUR_ROBOTS

PATH = os.path.join(OUR_ROBOTS, "four_bar.urdf")
# the numbers stated in robots/four_bar.urdf
L0, L1, L2, L3 = 0.4, 0.1, 0.35, 0.3
M1, M2, M3 = 0.5, 1.2, 0.9
R1, R2, R3 = L1 / 2, L2 / 2, L3 / 2
I1, I2, I3 = M1 * L1 ** 2 / 12, M2 * L2 ** 2 / 12, M3 * L3 ** 2 / 12
G = 9.81


def lectures(q, qd, tau):
    """(qdd, lambda, phi, Phi_q) of the lectures' formula, lambda = the loop force (x, vertical)."""
    t1, t2, p1 = q
    d1, d2, dp = qd
    c2 = np.cos(t2)
    M = np.array([[I1 + I2 + M1 * R1 ** 2 + M2 * (L1 ** 2 + R2 ** 2 + 2 * L1 * R2 * c2), I2 + M2 * (R2 ** 2 + L1 * R2 * c2), 0],
                  [I2 + M2 * (R2 ** 2 + L1 * R2 * c2), I2 + M2 * R2 ** 2, 0],
                  [0, 0, I3 + M3 * R3 ** 2]])
    h = -M2 * L1 * R2 * np.sin(t2)
    Cqd = np.array([h * (2 * d1 * d2 + d2 ** 2), -h * d1 ** 2, 0.0])
    Gq = np.array([(M1 * R1 + M2 * L1) * G * np.cos(t1) + M2 * R2 * G * np.cos(t1 + t2),
                   M2 * R2 * G * np.cos(t1 + t2), M3 * R3 * G * np.cos(p1)])
    s1, c1, s12, c12 = np.sin(t1), np.cos(t1), np.sin(t1 + t2), np.cos(t1 + t2)
    phi = np.array([L1 * c1 + L2 * c12 - L0 - L3 * np.cos(p1), L1 * s1 + L2 * s12 - L3 * np.sin(p1)])
    Phi = np.array([[-L1 * s1 - L2 * s12, -L2 * s12, L3 * np.sin(p1)],
                    [L1 * c1 + L2 * c12, L2 * c12, -L3 * np.cos(p1)]])
    Phid_qd = np.array([-L1 * c1 * d1 ** 2 - L2 * c12 * (d1 + d2) ** 2 + L3 * np.cos(p1) * dp ** 2,
                        -L1 * s1 * d1 ** 2 - L2 * s12 * (d1 + d2) ** 2 + L3 * np.sin(p1) * dp ** 2])
    f = tau - Cqd - Gq
    Minv = np.linalg.inv(M)
    lam = -np.linalg.solve(Phi @ Minv @ Phi.T, Phi @ Minv @ f + Phid_qd)
    return Minv @ (f + Phi.T @ lam), lam, phi, Phi


@pytest.fixture(scope="module")
def hinge():
    return dynamics.load_urdf(PATH)


@pytest.fixture(scope="module")
def point():
    """The same loop closed by a 3-row point closure instead of the URDF's 5-row hinge."""
    text = re.sub(r"<loop .*?</loop>", "", open(PATH).read(), flags=re.S)
    tree = dynamics.load_urdf(text)
    return dynamics.with_constraints(tree, [dynamics.PointConstraint("link2", "link3", (L2, 0, 0), (L3, 0, 0))])


def states(model, rng, n):
    for _ in range(n):
        guess = np.array([rng.uniform(-np.pi, np.pi), 0.5, 1.5])
        q = dynamics.assemble(model, guess, fixed=["theta1"])
        v = dynamics.project_velocity(model, q, rng.normal(size=3) * 3)
        yield q, v, rng.normal(size=3)


def test_the_urdf_is_the_lectures_crank_rocker(hinge):
    assert hinge.info["constraints"] == {"count": 1, "rows": 5, "rank": 2, "mobility": 1,
                                         "closed_near_assembly": True}
    assert (L1 + L0) <= (L2 + L3) and L1 == min(L0, L1, L2, L3)  # Grashof, crank next to the ground
    q = np.array([0.3, 1.0, 1.2])
    M = dynamics.mass_matrix(hinge, q)
    t2 = q[1]
    np.testing.assert_allclose(M[0, 0], I1 + I2 + M1 * R1 ** 2 + M2 * (L1 ** 2 + R2 ** 2 + 2 * L1 * R2 * np.cos(t2)),
                               rtol=1e-12)
    np.testing.assert_allclose(M[2, 2], I3 + M3 * R3 ** 2, rtol=1e-12)
    phi = dynamics.constraint_residual(hinge, q)
    np.testing.assert_allclose(phi[[0, 2]], lectures(q, np.zeros(3), np.zeros(3))[2], atol=1e-15)


@pytest.mark.parametrize("closure", ["hinge", "point"])
def test_accelerations_and_multipliers_match_the_lectures(closure, request):
    model = request.getfixturevalue(closure)
    rng = np.random.default_rng(1)
    for q, v, tau in states(model, rng, 5):
        a, lam = dynamics.constrained_forward_dynamics(model, q, v, tau)
        a_ref, lam_ref, phi, _ = lectures(q, v, tau)
        assert np.abs(phi).max() < 1e-12
        np.testing.assert_allclose(a, a_ref, rtol=0, atol=1e-11 * max(1, np.abs(a_ref).max()))
        # the force on link 2's tip in the plane (world x, z = the lectures' x, y); redundant rows carry nothing
        np.testing.assert_allclose(lam[[0, 2]], lam_ref, rtol=0, atol=1e-11 * max(1, np.abs(lam_ref).max()))
        np.testing.assert_allclose(np.delete(lam, [0, 2]), 0.0, atol=1e-11 * max(1, np.abs(lam_ref).max()))


def test_batch_equals_single_states(hinge):
    rng = np.random.default_rng(2)
    Q, V, T = map(np.array, zip(*states(hinge, rng, 4)))
    A, LAM = dynamics.constrained_forward_dynamics(hinge, Q, V, T, baumgarte=(3.0, 4.0))
    for k in range(4):
        a, lam = dynamics.constrained_forward_dynamics(hinge, Q[k], V[k], T[k], baumgarte=(3.0, 4.0))
        np.testing.assert_array_equal(A[k], a)
        np.testing.assert_array_equal(LAM[k], lam)


def test_ten_seconds_against_scipy_on_the_lectures_formula(hinge):
    """Both integrated by SciPy's DOP853 at rtol 1e-11: our constrained dynamics as the right-hand side
    against the lectures' closed form; a motor on the crank (2 N m stall torque, 0.2 N m s/rad back-EMF)
    turns it against gravity."""
    q0 = dynamics.assemble(hinge, np.array([0.2, 0.5, 1.5]), fixed=["theta1"])
    v0 = dynamics.project_velocity(hinge, q0, np.array([2.0, 0, 0]))

    def motor(x):
        return np.array([2.0 - 0.2 * x[3], 0.0, 0.0])

    def ours(t, x):
        a, _ = dynamics.constrained_forward_dynamics(hinge, x[:3], x[3:], motor(x))
        return np.concatenate([x[3:], a])

    def closed_form(t, x):
        return np.concatenate([x[3:], lectures(x[:3], x[3:], motor(x))[0]])

    x0 = np.concatenate([q0, v0])
    opts = dict(method="DOP853", rtol=1e-11, atol=1e-11, t_eval=np.linspace(0, 10, 11))
    ref = solve_ivp(closed_form, (0, 10), x0, **opts)
    got = solve_ivp(ours, (0, 10), x0, **opts)
    assert ref.success and got.success
    assert np.abs(got.y - ref.y).max() < 1e-7
    assert abs(got.y[0, -1] - q0[0]) > 2 * np.pi  # the crank turned fully: a crank-rocker
    drift = max(np.abs(dynamics.constraint_residual(hinge, got.y[:3, k])).max() for k in range(11))
    assert drift < 1e-7


def _drift(model, baumgarte, q0, v0):
    """Largest |phi| over 10 s of a passive swing at a loose tolerance."""
    def rhs(t, x):
        a, _ = dynamics.constrained_forward_dynamics(model, x[:3], x[3:], np.zeros(3), baumgarte=baumgarte)
        return np.concatenate([x[3:], a])

    sol = solve_ivp(rhs, (0, 10), np.concatenate([q0, v0]), method="RK45", rtol=1e-5, atol=1e-7,
                    t_eval=np.linspace(0, 10, 101))
    phi = dynamics.constraint_residual(model, np.ascontiguousarray(sol.y[:3].T))
    energy = (dynamics.kinetic_energy(model, sol.y[:3, -1], sol.y[3:, -1])
              + dynamics.potential_energy(model, sol.y[:3, -1]))
    return np.abs(phi).max(), energy


def test_drift_with_and_without_baumgarte(hinge):
    q0 = dynamics.assemble(hinge, np.array([1.0, 0.5, 1.5]), fixed=["theta1"])
    v0 = dynamics.project_velocity(hinge, q0, np.array([3.0, 0, 0]))
    e0 = dynamics.kinetic_energy(hinge, q0, v0) + dynamics.potential_energy(hinge, q0)
    free, e_free = _drift(hinge, None, q0, v0)
    held, e_held = _drift(hinge, (10.0, 10.0), q0, v0)
    assert held < free / 10, (held, free)
    assert held < 1e-5
    # a passive loop conserves energy: lambda does no work (up to the loose tolerance)
    assert abs(e_held - e0) < 1e-3 * abs(e0)


def test_assembly_of_the_crank_rocker(hinge):
    for crank in np.linspace(-np.pi, np.pi, 9):
        q = dynamics.assemble(hinge, np.array([crank, 0.5, 1.5]), fixed={"theta1": crank})
        assert q[0] == crank
        assert np.abs(lectures(q, np.zeros(3), np.zeros(3))[2]).max() < 1e-12
