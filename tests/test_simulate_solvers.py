"""The core's solvers (core/simulation/) on plain ODEs, against closed forms and scipy at rtol 1e-12: a linear
system z' = A z or Van der Pol, written in Python and run through _core.solve_ode; and their linear algebra (LU,
the envelope LU that radau uses, the spectral radius) against numpy.
"""

from typing import NamedTuple

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from dynamics import _core
from dynamics.simulation import solvers as S


def solve(method, z0, t1, *, A=None, mu=0.0, dt=0.01, rtol=1e-6, atol=1e-9, out_t=None, max_steps=10**6):
    """z' = A z (or Van der Pol y'' = mu (1 - y^2) y' - y when ``mu`` > 0) by the core's ``method`` from (0, z0)
    to t1; returns (z(t1), the samples (t, z), the statistics, the switches)."""
    z0 = np.array(z0, float)
    n = z0.shape[0]
    A = np.zeros((n, n)) if A is None else np.asarray(A, float)

    def f(t, z):
        if mu > 0:
            return np.array([z[1], mu * (1.0 - z[0] * z[0]) * z[1] - z[0]])
        return A @ z

    out_t = np.array([0.0, t1]) if out_t is None else np.array(out_t, float)
    out_z = np.zeros((len(out_t), n))
    opt = S.Options(nc=n // 2, nvel=n - n // 2, ne=n, max_steps=max_steps, nsteps=int(np.ceil(t1 / dt * (1 - 1e-12))),
                    dt=float(dt), rtol=rtol, atol=atol, h0=0.0, hmax=np.inf, blowup=1e12, probe=False)
    stats, sw = S.new_stats(), S.new_switch_log()
    z = z0.copy()
    _core.solve_ode(method, f, z, float(t1), out_t, out_z, opt._asdict(), stats, sw)
    st = stats[0]
    return z, Samples(out_t, out_z), st, sw[:st["switches"]]


class Samples(NamedTuple):
    out_t: np.ndarray
    out_z: np.ndarray


OSC = np.array([[0.0, 1.0], [-1.0, 0.0]])  # x'' = -x


def exact_osc(t):
    return np.array([np.cos(t), -np.sin(t)])


@pytest.mark.parametrize("method, order", [("euler", 1), ("rk4", 4)])
def test_fixed_step_order(method, order):
    errs = [np.abs(solve(method, [1, 0], 5.0, A=OSC, dt=dt)[0] - exact_osc(5.0)).max() for dt in (0.02, 0.01)]
    assert errs[0] / errs[1] == pytest.approx(2 ** order, rel=0.15)


def test_fixed_step_samples_and_last_step():
    # dt does not divide the duration: the last step is shortened and lands exactly on t1
    out = np.linspace(0, 1.05, 8)
    z, p, st, _ = solve("rk4", [1, 0], 1.05, A=OSC, dt=0.1, out_t=out)
    assert p.out_t[-1] == 1.05 and st["steps"] == 11
    assert np.abs(p.out_z - exact_osc(out).T).max() < 1e-5  # Hermite samples between steps


@pytest.mark.parametrize("method", ["rk45", "dop853", "radau", "auto"])
@pytest.mark.parametrize("tol", [1e-5, 1e-9])
def test_adaptive_accuracy_and_dense_output(method, tol):
    rng = np.random.default_rng(1)
    A = rng.normal(size=(4, 4)) - 0.5 * np.eye(4)
    z0 = rng.normal(size=4)
    out = np.linspace(0, 3, 31)
    z, p, st, _ = solve(method, z0, 3.0, A=A, rtol=tol, atol=tol, out_t=out)
    exact = np.array([expm(A * t) @ z0 for t in out])
    assert np.abs(z - exact[-1]).max() < 200 * tol
    assert np.abs(p.out_z - exact).max() < 2000 * tol  # dense output, lower order between steps
    assert st["status"] == S.OK


def test_radau_on_stiff_linear_system_takes_few_steps():
    # eigenvalues -1e6 and -1 +- 10i: rk45 would need ~ 1e6 steps for 1 s
    A = np.array([[-1e6, 0, 0], [0, -1, 10], [0, -10, -1]])
    z0 = np.array([1.0, 1.0, 0.0])
    z, p, st, _ = solve("radau", z0, 1.0, A=A, rtol=1e-8, atol=1e-10)
    assert np.abs(z - expm(A) @ z0).max() < 1e-7
    assert st["steps"] < 1000


def test_rk45_detects_stiffness_and_auto_switches_both_ways():
    mu = 1000.0
    ref = solve_ivp(lambda t, y: [y[1], mu * (1 - y[0] ** 2) * y[1] - y[0]], (0, 1000), [2, 0], method="Radau",
                    rtol=1e-12, atol=1e-12).y[:, -1]
    z, _, st, switches = solve("auto", [2, 0], 1000.0, mu=mu, rtol=1e-8, atol=1e-8)
    assert abs(z[0] - ref[0]) < 1e-4
    to = switches["to"].tolist()
    assert to[0] == S.RADAU and S.RK45 in to  # stiff on the slow branch, explicit on the fast jumps
    assert st["steps"] < 20000
    # plain rk45 notices the stiffness (and says when), even if it does not switch
    _, _, st45, _ = solve("rk45", [2, 0], 50.0, mu=mu, rtol=1e-6, atol=1e-6)
    assert 0 < st45["stiff_t"] < 50 and st45["stiff_hits"] >= 15


def test_fixed_step_blowup_is_reported():
    A = np.array([[-1e4, 0.0], [0.0, -1.0]])
    z, _, st, _ = solve("rk4", [1.0, 1.0], 1.0, A=A, dt=0.01)
    assert st["status"] in (S.NONFINITE, S.BLOWUP) and st["t"] < 1.0


def test_max_steps_status():
    _, _, st, _ = solve("rk45", [1, 0], 100.0, A=OSC, rtol=1e-10, atol=1e-10, max_steps=50)
    assert st["status"] == S.MAX_STEPS


def test_lu_solve_real_and_complex():
    rng = np.random.default_rng(0)
    for dtype in (np.float64, np.complex128):
        A = rng.normal(size=(7, 7)) + (1j * rng.normal(size=(7, 7)) if dtype is np.complex128 else 0)
        b = rng.normal(size=7).astype(dtype)
        LU, piv, x, env = A.astype(dtype).copy(), np.zeros(7, np.int32), b.copy(), np.zeros(21, np.int32)
        LUe, pive, xe = LU.copy(), piv.copy(), x.copy()
        _core.lu_factor(LU, piv)
        _core.lu_solve(LU, piv, x)
        _core.envelope_lu_factor(LUe, pive, env)
        _core.envelope_lu_solve(LUe, pive, env, xe)
        assert np.allclose(A @ x, b, atol=1e-12) and np.allclose(A @ xe, b, atol=1e-12)


def _block_diagonal(rng, b, blocks, extra, dtype):
    """blocks copies of one random b x b block on the diagonal (the sensitivities' Newton matrix), ``extra`` rows
    at the bottom that read the first block's columns (its quadratures), a shift on the diagonal."""
    n = b * blocks + extra
    block = rng.normal(size=(b, b)) + (1j * rng.normal(size=(b, b)) if dtype is np.complex128 else 0)
    A = np.zeros((n, n), dtype)
    for k in range(blocks):
        A[k * b:(k + 1) * b, k * b:(k + 1) * b] = block
    A[n - extra:, :b] = rng.normal(size=(extra, b))
    return A + 0.5 * np.eye(n)


@pytest.mark.parametrize("dtype", [np.float64, np.complex128])
def test_envelope_lu_equals_dense_lu_bit_for_bit(dtype):
    """radau's LU skips only exact zeros: the same factors and solutions as the dense one, bit for bit, on dense
    matrices, on block-diagonal ones with rows below (pivoting across the envelope: the bottom rows are large),
    and on a matrix with a NaN."""
    rng = np.random.default_rng(1)
    cases = [rng.normal(size=(9, 9)).astype(dtype), _block_diagonal(rng, 6, 5, 2, dtype)]
    big = _block_diagonal(rng, 4, 3, 2, dtype)
    big[-2:, :4] *= 1e3  # the bottom rows win the pivot search of the first block's columns: fill-in
    cases += [big, np.where(rng.random((8, 8)) < 0.6, 0.0, rng.normal(size=(8, 8))).astype(dtype) + np.eye(8)]
    nan = rng.normal(size=(6, 6)).astype(dtype)
    nan[3, 1] = np.nan
    cases.append(nan)
    for A in cases:
        n = A.shape[0]
        LU, piv = A.copy(), np.zeros(n, np.int32)
        LUe, pive, env = A.copy(), np.zeros(n, np.int32), np.zeros(3 * n, np.int32)
        _core.lu_factor(LU, piv)
        _core.envelope_lu_factor(LUe, pive, env)
        assert np.array_equal(piv, pive) and np.array_equal(LU, LUe, equal_nan=True)
        b = rng.normal(size=n).astype(dtype)
        x, xe = b.copy(), b.copy()
        _core.lu_solve(LU, piv, x)
        _core.envelope_lu_solve(LUe, pive, env, xe)
        assert np.array_equal(x, xe, equal_nan=True)
        if np.isfinite(A).all():
            assert np.allclose(A @ x, b, atol=1e-9 * np.abs(A).max() * np.abs(x).max())


def test_spectral_radius_of_a_block_diagonal_matrix_is_its_blocks():
    """The power iteration reads only each row's nonzero span: on a block-diagonal matrix (a dominant eigenvalue
    -40, well separated) it finds the block's, as numpy's eigenvalues."""
    rng = np.random.default_rng(2)
    Q = rng.normal(size=(5, 5))
    block = Q @ np.diag([-40.0, 3.0, -2.0, 1.0, 0.5]) @ np.linalg.inv(Q)
    A = np.kron(np.eye(4), block)
    assert np.isclose(_core.spectral_radius(A, 20), 40.0, rtol=1e-6)


def test_the_test_hooks_refuse_bad_input():
    """_core.solve_ode and the LU entries name what is wrong (shapes, dtypes, a failing f) and never crash."""
    opt = S.Options(nc=1, nvel=1, ne=2, max_steps=100, nsteps=10, dt=0.1, rtol=1e-6, atol=1e-9, h0=0.0, hmax=np.inf,
                    blowup=1e12, probe=False)._asdict()
    z, out_t, out_z = np.array([1.0, 0.0]), np.array([0.0, 1.0]), np.zeros((2, 2))
    stats, sw = S.new_stats(), S.new_switch_log()
    f = lambda t, x: OSC @ x  # noqa: E731
    for args in [("rk45", f, z, 1.0, out_t, np.zeros((3, 2))), ("rk45", f, z.astype(np.float32), 1.0, out_t, out_z),
                 ("magic", f, z, 1.0, out_t, out_z), ("rk45", lambda t, x: np.zeros(3), z, 1.0, out_t, out_z),
                 ("rk45", f, z, 1.0, out_t, out_z[:, ::2])]:
        with pytest.raises((ValueError, TypeError)):
            _core.solve_ode(*args, opt, stats, sw)
    with pytest.raises(ZeroDivisionError):  # f's own exception, raised after the run
        _core.solve_ode("rk45", lambda t, x: 1 / 0, z.copy(), 1.0, out_t, out_z, opt, stats, sw)
    for call in (lambda: _core.lu_factor(np.zeros((3, 4)), np.zeros(3, np.int32)),
                 lambda: _core.lu_factor(np.zeros((3, 3)), np.zeros(2, np.int32)),
                 lambda: _core.lu_solve(np.eye(3), np.zeros(3, np.int32), np.zeros(2)),
                 lambda: _core.envelope_lu_factor(np.eye(3), np.zeros(3, np.int32), np.zeros(3, np.int32)),
                 lambda: _core.spectral_radius(np.eye(3), 4)):
        with pytest.raises((ValueError, TypeError)):
            call()


def _second_order_jacobian(rng, blocks, nw):
    """A Jacobian with the robot's structure: z = [delta, v, w], the chart rows per joint (Jcd, Jcv block-diagonal,
    a 1-dof joint's zero and one), dense acceleration rows, quadrature rows, zero w columns."""
    nv = blocks[-1]
    n = 2 * nv + nw
    J = np.zeros((n, n))
    for k0, k1 in zip(blocks, blocks[1:]):
        m = k1 - k0
        if m == 1:
            J[k0, nv + k0] = 1.0
        else:
            J[k0:k1, k0:k1] = 0.3 * rng.normal(size=(m, m))
            J[k0:k1, nv + k0:nv + k1] = np.eye(m) + 0.2 * rng.normal(size=(m, m))
    J[nv:, :2 * nv] = 5.0 * rng.normal(size=(nv + nw, 2 * nv))
    return J


@pytest.mark.parametrize("mu", [3.6, 2.7 - 3.1j, 1e4])
def test_reduced_solve_is_the_whole_systems_solution(mu):
    """radau's systems reduced to the velocities (core/simulation/second_order.hpp) against numpy's solve of the
    whole (2 nv + nw) system: a floating base (6), 1-dof joints and a spherical joint, real and complex shifts."""
    rng = np.random.default_rng(7)
    blocks = [0, 6, 7, 8, 11, 12]
    J = _second_order_jacobian(rng, blocks, 3)
    n = J.shape[0]
    dtype = np.complex128 if isinstance(mu, complex) else np.float64
    b = (rng.normal(size=n) + (1j * rng.normal(size=n) if dtype is np.complex128 else 0)).astype(dtype)
    x = b.copy()
    _core.reduced_solve(J, np.array(blocks, np.int32), mu, x)
    want = np.linalg.solve(mu * np.eye(n) - J, b)
    np.testing.assert_allclose(x, want, rtol=1e-11, atol=1e-12 * np.abs(want).max())


def test_reduced_solve_refuses_bad_blocks():
    J = np.eye(6)
    for blocks in ([1, 3], [0, 2, 2], [0, 4], [0]):
        with pytest.raises(ValueError, match="blocks"):
            _core.reduced_solve(J, np.array(blocks, np.int32), 1.0, np.zeros(6))
