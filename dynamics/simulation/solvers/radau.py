"""Radau IIA of order 5 (3 stages, L-stable, stiffly accurate) with a simplified Newton iteration on the
problem's Jacobian (analytical for the robot, :mod:`dynamics.simulation.jacobian`; finite differences for a
problem without one, :func:`.linalg.problem_jacobian`), the real/complex splitting of the stage system, the
embedded third-order error estimate filtered through (1 - h gamma J)^-1 and Gustafsson's predictive controller
([HW] sec. IV.8; the structure follows ``scipy.integrate.Radau``).  Dense output: the collocation polynomial of the step.

[HW] = Hairer & Wanner, "Solving ODEs II", 2nd ed. 1996.
"""

from typing import NamedTuple

import numpy as np

from ..._numba import generic_inline, kernel
from .interface import OK, problem_rhs
from .linalg import envelope_lu_factor, envelope_lu_solve, problem_jacobian, scaled_rms, spectral_radius, state_status

ORDER = 3  # for the starting step (the embedded estimate's order)
EPS = 2.220446049250313e-16

# Radau IIA(5) ([HW] sec. IV.8): nodes, error weights, A = T diag(mu) T^-1 split, dense output
_S6 = 6 ** 0.5
RA_C = np.array([(4 - _S6) / 10, (4 + _S6) / 10, 1.0])
RA_E = np.array([-13 - 7 * _S6, -13 + 7 * _S6, -1.0]) / 3
RA_MU_REAL = 3 + 3 ** (2 / 3) - 3 ** (1 / 3)
RA_MU_CRE = 3 + 0.5 * (3 ** (1 / 3) - 3 ** (2 / 3))
RA_MU_CIM = -0.5 * (3 ** (5 / 6) + 3 ** (7 / 6))
RA_T = np.array([
    [0.09443876248897524, -0.14125529502095421, 0.03002919410514742],
    [0.25021312296533332, 0.20412935229379994, -0.38294211275726192],
    [1, 1, 0]])
RA_TI = np.array([
    [4.17871859155190428, 0.32768282076106237, 0.52337644549944951],
    [-4.17871859155190428, -0.32768282076106237, 0.47662355450055044],
    [0.50287263494578682, -2.57192694985560522, 0.59603920482822492]])
RA_P = np.array([
    [13 / 3 + 7 * _S6 / 3, -23 / 3 - 22 * _S6 / 3, 10 / 3 + 5 * _S6],
    [13 / 3 - 7 * _S6 / 3, -23 / 3 + 22 * _S6 / 3, 10 / 3 - 5 * _S6],
    [1 / 3, -8 / 3, 10 / 3]])
NEWTON_MAXITER = 6

CTL = np.dtype([
    ("need_jac", np.int64), ("current_jac", np.int64), ("have_lu", np.int64), ("have_sol", np.int64),
    ("h_sol", np.float64),  # size of the step whose collocation polynomial Qd holds
    ("h_abs_old", np.float64), ("err_norm_old", np.float64),  # Gustafsson's controller memory (< 0: none)
    ("rho", np.float64),  # spectral radius of the last Jacobian (< 0: none yet)
    ("n_iter", np.int64), ("rate", np.float64),  # the last Newton iteration
], align=True)


class Radau(NamedTuple):
    J: np.ndarray  # (n, n) Jacobian df/dz at the start of the step that computed it
    LUr: np.ndarray  # (n, n) LU of mu_real/h - J
    LUc: np.ndarray  # (n, n) complex LU of mu_complex/h - J
    pivr: np.ndarray
    pivc: np.ndarray
    envr: np.ndarray  # (3, n) the envelopes of the two LUs (linalg.envelope_lu_factor)
    envc: np.ndarray
    Z: np.ndarray  # (3, n) stage increments
    W: np.ndarray  # (3, n) transformed increments T^-1 Z
    F: np.ndarray  # (3, n) f at the stages
    Qd: np.ndarray  # (n, 3) collocation polynomial of the last accepted step
    zs: np.ndarray  # (n,) stage state
    dWr: np.ndarray
    dWc: np.ndarray
    ctl: np.ndarray  # (1,) CTL


@kernel
def make(n):
    ctl = np.zeros(1, CTL)
    m = Radau(np.zeros((n, n)), np.empty((n, n)), np.empty((n, n), np.complex128), np.empty(n, np.int64),
              np.empty(n, np.int64), np.empty((3, n), np.int64), np.empty((3, n), np.int64), np.zeros((3, n)),
              np.zeros((3, n)), np.empty((3, n)), np.zeros((n, 3)),
              np.empty(n), np.empty(n), np.empty(n, np.complex128), ctl)
    reset(m)
    return m


@kernel
def reset(m):
    """Forget Jacobian, LU, controller memory and the last polynomial (a fresh start, or ``auto``
    switching to this method)."""
    c = m.ctl[0]
    c.need_jac = 1
    c.current_jac = 0
    c.have_lu = 0
    c.have_sol = 0
    c.h_sol = 1.0
    c.h_abs_old = -1.0
    c.err_norm_old = -1.0
    c.rho = -1.0


@generic_inline
def attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    """Solve the stage system (a fresh Jacobian once if Newton fails), estimate the error, run Gustafsson's
    controller; on acceptance also f at the new point (Radau is not FSAL).  Returns (accepted, next h)."""
    c = m.ctl[0]
    n = z.shape[0]
    while True:
        if c.need_jac:
            problem_jacobian(p, t, z, f0, mag, opt.ne, m.J, st)
            c.rho = spectral_radius(m.J, opt.ne)
            c.need_jac = 0
            c.current_jac = 1
            c.have_lu = 0
        if not c.have_lu:
            _factor(m, h, st)
        converged = _newton(m, p, t, h, z, mag, opt, st)
        if converged or c.current_jac:
            break
        c.need_jac = 1  # retry once with a fresh Jacobian
    if not converged:
        c.have_lu = 0
        return False, h * 0.5
    for r in range(n):
        znew[r] = z[r] + m.Z[2, r]
    err = _error(m, h, z, znew, f0, errv, mag, opt)
    if not np.isfinite(err):
        c.have_lu = 0
        return False, h * 0.25
    safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + c.n_iter)
    # Gustafsson's predictive controller ([HW] IV.8, eq. 8.25)
    if c.err_norm_old < 0 or c.h_abs_old < 0 or err == 0:
        mult = 1.0
    else:
        mult = h / c.h_abs_old * (c.err_norm_old / err) ** 0.25
    factor = min(1.0, mult) * (err ** -0.25 if err > 0 else 10.0)
    if err > 1:
        c.have_lu = 0
        return False, h * max(0.2, safety * factor)
    recompute_jac = c.n_iter > 2 and c.rate > 1e-3
    factor = min(10.0, safety * factor)
    if not recompute_jac and factor < 1.2:
        factor = 1.0
    else:
        c.have_lu = 0
    c.h_abs_old = h
    c.err_norm_old = err
    c.need_jac = 1 if recompute_jac else c.need_jac
    c.current_jac = 0
    _collocation_polynomial(m, h)
    if c.rho >= 0 and not st.h_rho >= h * c.rho:
        st.h_rho = h * c.rho
    problem_rhs(p, t + h, znew, fnew)
    st.rhs_evals += 1
    return True, h * factor


@kernel
def _factor(m, h, st):
    """LU of mu_real/h - J and of mu_complex/h - J (the two blocks of the transformed stage system)."""
    mr = RA_MU_REAL / h
    mc = complex(RA_MU_CRE, RA_MU_CIM) / h
    n = m.J.shape[0]
    for r in range(n):
        for k in range(n):
            m.LUr[r, k] = -m.J[r, k]
            m.LUc[r, k] = -m.J[r, k]
        m.LUr[r, r] += mr
        m.LUc[r, r] += mc
    envelope_lu_factor(m.LUr, m.pivr, m.envr)
    envelope_lu_factor(m.LUc, m.pivc, m.envc)
    st.lu_decompositions += 2
    m.ctl[0].have_lu = 1


@generic_inline
def _newton(m, p, t, h, z, mag, opt, st):
    """Simplified Newton iterations on the transformed stage system ([HW] IV.8, eqs. 8.14-8.16), starting
    from the last step's collocation polynomial (increments are chart-free to first order) or zero.
    Leaves the increments in Z, the iteration count and rate in ctl; returns whether it converged."""
    c = m.ctl[0]
    Z, W, F, zs, dWr, dWc = m.Z, m.W, m.F, m.zs, m.dWr, m.dWc
    n = z.shape[0]
    mr = RA_MU_REAL / h
    mc = complex(RA_MU_CRE, RA_MU_CIM) / h
    newton_tol = max(10 * EPS / opt.rtol, min(0.03, opt.rtol ** 0.5))
    _initial_guess(m, h)
    dW_norm_old = -1.0
    c.rate = -1.0
    c.n_iter = 0
    for it in range(NEWTON_MAXITER):
        c.n_iter = it + 1
        finite = True
        for s in range(3):
            for r in range(n):
                zs[r] = z[r] + Z[s, r]
            problem_rhs(p, t + RA_C[s] * h, zs, F[s])
            if state_status(F[s], 0, 0, np.inf) != OK:
                finite = False
        st.rhs_evals += 3
        if not finite:
            return False
        for r in range(n):
            dWr[r] = RA_TI[0, 0] * F[0, r] + RA_TI[0, 1] * F[1, r] + RA_TI[0, 2] * F[2, r] - mr * W[0, r]
            dWc[r] = (complex(RA_TI[1, 0], RA_TI[2, 0]) * F[0, r] + complex(RA_TI[1, 1], RA_TI[2, 1]) * F[1, r]
                      + complex(RA_TI[1, 2], RA_TI[2, 2]) * F[2, r] - mc * complex(W[1, r], W[2, r]))
        envelope_lu_solve(m.LUr, m.pivr, m.envr, dWr)
        envelope_lu_solve(m.LUc, m.pivc, m.envc, dWc)
        acc = 0.0
        for r in range(opt.ne):
            sc = opt.atol + opt.rtol * (abs(z[r]) + mag[r])
            acc += (dWr[r] / sc) ** 2 + (dWc[r].real / sc) ** 2 + (dWc[r].imag / sc) ** 2
        dW_norm = np.sqrt(acc / (3 * max(opt.ne, 1)))
        if not np.isfinite(dW_norm):
            return False
        if dW_norm_old > 0:
            c.rate = dW_norm / dW_norm_old
        rate = c.rate
        if rate >= 0 and (rate >= 1 or rate ** (NEWTON_MAXITER - it) / (1 - rate) * dW_norm > newton_tol):
            return False
        for r in range(n):
            W[0, r] += dWr[r]
            W[1, r] += dWc[r].real
            W[2, r] += dWc[r].imag
        for s in range(3):
            for r in range(n):
                Z[s, r] = RA_T[s, 0] * W[0, r] + RA_T[s, 1] * W[1, r] + RA_T[s, 2] * W[2, r]
        if dW_norm == 0 or (rate >= 0 and rate / (1 - rate) * dW_norm < newton_tol):
            return True
        dW_norm_old = dW_norm
    return False


@kernel
def _initial_guess(m, h):
    c = m.ctl[0]
    Z, W, Qd = m.Z, m.W, m.Qd
    n = Z.shape[1]
    if c.have_sol:
        for s in range(3):
            x1 = 1.0 + RA_C[s] * h / c.h_sol
            for r in range(n):
                Z[s, r] = Qd[r, 0] * (x1 - 1.0) + Qd[r, 1] * (x1 * x1 - 1.0) + Qd[r, 2] * (x1 * x1 * x1 - 1.0)
    else:
        Z[:, :] = 0.0
    for s in range(3):
        for r in range(n):
            W[s, r] = RA_TI[s, 0] * Z[0, r] + RA_TI[s, 1] * Z[1, r] + RA_TI[s, 2] * Z[2, r]


@kernel
def _error(m, h, z, znew, f0, errv, mag, opt):
    """Embedded error estimate, filtered ([HW] IV.8, eq. 8.20): err = (mu_real/h - J)^-1 (f0 + Z^T E / h)."""
    Z = m.Z
    for r in range(z.shape[0]):
        errv[r] = f0[r] + (Z[0, r] * RA_E[0] + Z[1, r] * RA_E[1] + Z[2, r] * RA_E[2]) / h
    envelope_lu_solve(m.LUr, m.pivr, m.envr, errv)
    return scaled_rms(errv, z, znew, mag, opt.ne, opt.rtol, opt.atol)


@kernel
def _collocation_polynomial(m, h):
    """This step's dense output Qd (also the next step's Newton starting guess)."""
    Z, Qd = m.Z, m.Qd
    for r in range(Z.shape[1]):
        for k in range(3):
            Qd[r, k] = Z[0, r] * RA_P[0, k] + Z[1, r] * RA_P[1, k] + Z[2, r] * RA_P[2, k]
    m.ctl[0].have_sol = 1
    m.ctl[0].h_sol = h


@generic_inline
def dense(m, p, t0, h, x, z0, z1, out, st):
    Qd = m.Qd
    for r in range(out.shape[0]):
        out[r] = z0[r] + x * (Qd[r, 0] + x * (Qd[r, 1] + x * Qd[r, 2]))


@kernel
def order(m):
    return ORDER


Radau.attempt = attempt
Radau.dense = dense
Radau.order = order
