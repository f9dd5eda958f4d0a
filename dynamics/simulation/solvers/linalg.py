"""Numerical pieces shared by the solvers: LU with partial pivoting (real and complex), the scaled RMS norm,
the state check, Hairer's starting step, the finite-difference Jacobian and a spectral-radius estimate.

[HNW] = Hairer, Norsett & Wanner, "Solving ODEs I", 2nd ed. 1993.
"""

import numpy as np
from numba.extending import overload

from ..._numba import GENERIC_OPTIONS, generic_inline, helper, kernel
from .interface import BLOWUP, NONFINITE, OK, STATS, driver_rhs


@kernel
def lu_factor(A, piv):
    """In-place LU with partial pivoting (real or complex A): P A = L U, L unit lower triangular."""
    n = A.shape[0]
    for k in range(n):
        m = k
        big = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                m = i
        piv[k] = m
        if m != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[m, j]
                A[m, j] = tmp
        d = A[k, k]
        if d == 0:
            continue  # singular: the solve returns inf/nan and the step is rejected
        for i in range(k + 1, n):
            A[i, k] /= d
            lik = A[i, k]
            if lik != 0:
                for j in range(k + 1, n):
                    A[i, j] -= lik * A[k, j]


@kernel
def _permute(piv, b, n):
    """b (n) in the row order of lu_factor's pivots."""
    for k in range(n):
        m = piv[k]
        if m != k:
            tmp = b[k]
            b[k] = b[m]
            b[m] = tmp


@kernel
def lu_solve(LU, piv, b):
    """Solve (P^T L U) x = b in place, given lu_factor's output."""
    n = LU.shape[0]
    _permute(piv, b, n)
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= LU[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= LU[i, j] * b[j]
        b[i] = s / LU[i, i]


@kernel
def envelope_lu_factor(A, piv, env):
    """:func:`lu_factor` that visits only each row's and column's envelope (the span of its nonzeros, widened by
    the fill-in as it comes): the same factors bit for bit, since only exact zeros are skipped, in O(n b^2)
    instead of O(n^2 b) for a block-diagonal A of b x b blocks (radau's Newton matrix of the sensitivities'
    augmented system).  env (3, n) int64 receives, for :func:`envelope_lu_solve`: env[0, i] the first column of
    row i's multipliers, env[1, i] the last nonzero column of row i of U; env[2] is scratch (the last nonzero
    row of each column)."""
    n = A.shape[0]
    lo, hi, bot = env[0], env[1], env[2]
    for i in range(n):
        lo[i], hi[i], bot[i] = i, i, i
    for i in range(n):
        for j in range(n):
            if A[i, j] != 0:  # (NaN too)
                hi[i] = max(hi[i], j)
                bot[j] = max(bot[j], i)
    for k in range(n):
        m = k
        big = abs(A[k, k])
        for i in range(k + 1, bot[k] + 1):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                m = i
        piv[k] = m
        if m != k:
            for j in range(k, hi[k] + 1):  # row k's entries move to row m
                bot[j] = max(bot[j], m)
            for j in range(min(lo[k], lo[m]), max(hi[k], hi[m]) + 1):
                tmp = A[k, j]
                A[k, j] = A[m, j]
                A[m, j] = tmp
            lo[k], lo[m] = lo[m], lo[k]
            hi[k], hi[m] = hi[m], hi[k]
        d = A[k, k]
        if d == 0:
            continue  # singular: the solve returns inf/nan and the step is rejected
        hk = hi[k]
        for i in range(k + 1, bot[k] + 1):
            A[i, k] /= d
            lik = A[i, k]
            if lik != 0:
                lo[i] = min(lo[i], k)
                hi[i] = max(hi[i], hk)
                for j in range(k + 1, hk + 1):
                    A[i, j] -= lik * A[k, j]
                    bot[j] = max(bot[j], i)


@kernel
def envelope_lu_solve(LU, piv, env, b):
    """:func:`lu_solve` for :func:`envelope_lu_factor`'s output: each row's sums over its envelope only."""
    n = LU.shape[0]
    lo, hi = env[0], env[1]
    _permute(piv, b, n)
    for i in range(n):
        s = b[i]
        for j in range(lo[i], i):
            s -= LU[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, hi[i] + 1):
            s -= LU[i, j] * b[j]
        b[i] = s / LU[i, i]


@kernel
def scaled_rms(e, z0, z1, mag, ne, rtol, atol):
    """RMS of e_i / (atol + rtol max(|z0_i| + mag_i, |z1_i| + mag_i)) over the first ne components."""
    s = 0.0
    for i in range(ne):
        sc = atol + rtol * max(abs(z0[i]) + mag[i], abs(z1[i]) + mag[i])
        x = e[i] / sc
        s += x * x
    return np.sqrt(s / max(ne, 1))


@kernel
def max_abs(x, ne):
    m = 0.0
    for i in range(ne):
        a = abs(x[i])
        if not a <= m:  # also propagates NaN
            m = a
    return m


@helper
def state_status(z, nc, nvel, blowup):
    """OK, NONFINITE or BLOWUP for a state (velocities above ``blowup`` count as a blow-up).  A helper, not a
    kernel: numba compiles a kernel once per literal argument its compiled callers pass (``0, 0`` and the
    options' fields made two), and a helper for the plain types."""
    for i in range(z.shape[0]):
        if not np.isfinite(z[i]):
            return NONFINITE
    for i in range(nc, nc + nvel):
        if abs(z[i]) > blowup:
            return BLOWUP
    return OK


@generic_inline
def initial_step(p, t, z, f0, order, rtol, atol, mag, ne, t_end, st):
    """Hairer's starting step ([HNW] sec. II.4), as scipy's ``select_initial_step``."""
    n = z.shape[0]
    span = t_end - t
    if span <= 0:
        return 0.0
    d0 = 0.0
    d1 = 0.0
    for i in range(ne):
        sc = atol + rtol * (abs(z[i]) + mag[i])
        d0 += (z[i] / sc) ** 2
        d1 += (f0[i] / sc) ** 2
    d0 = np.sqrt(d0 / max(ne, 1))
    d1 = np.sqrt(d1 / max(ne, 1))
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, span)
    z1 = np.empty(n)
    f1 = np.empty(n)
    for i in range(n):
        z1[i] = z[i] + h0 * f0[i]
    driver_rhs(p, t + h0, z1, f1)
    st.rhs_evals += 1
    d2 = 0.0
    for i in range(ne):
        sc = atol + rtol * (abs(z[i]) + mag[i])
        d2 += ((f1[i] - f0[i]) / sc) ** 2
    d2 = np.sqrt(d2 / max(ne, 1)) / h0
    if not np.isfinite(d2):
        return h0 * 1e-3
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100 * h0, h1, span)


@generic_inline
def fd_jacobian(p, t, z, f0, mag, ne, J, st):
    """Forward-difference Jacobian J = df/dz; columns of quadrature components (>= ne) are zero."""
    n = z.shape[0]
    zt = z.copy()
    ft = np.empty(n)
    for c in range(n):
        if c >= ne:
            for r in range(n):
                J[r, c] = 0.0
            continue
        d = 1.4901161193847656e-08 * max(1.0, abs(z[c]) + mag[c])
        zt[c] = z[c] + d
        d = zt[c] - z[c]  # the step actually representable
        driver_rhs(p, t, zt, ft)
        zt[c] = z[c]
        for r in range(n):
            J[r, c] = (ft[r] - f0[r]) / d
    st.rhs_evals += ne
    st.jacobian_evals += 1


def problem_jacobian(p, t, z, f0, mag, ne, J, st):
    """J = df/dz at (t, z) (f0 = f(t, z)): the problem class's own ``jacobian`` function (same arguments; the
    robot's is assembled from the derivatives of its parts, :mod:`dynamics.simulation.jacobian`) when it has
    one, else :func:`fd_jacobian`.  Compiled code only (chosen at compile time from ``type(p)``)."""
    raise NotImplementedError("problem_jacobian: compiled code only")


@overload(problem_jacobian, jit_options=GENERIC_OPTIONS)
def _ov_problem_jacobian(p, t, z, f0, mag, ne, J, st):
    fn = getattr(getattr(p, "instance_class", None), "jacobian", None)
    if fn is None:
        return fd_jacobian.py_func
    return getattr(fn, "py_func", fn)


@kernel
def spectral_radius(J, ne):
    """Estimate of max |lambda(J)| by 30 power iterations (geometric mean of the last 15 growth ratios;
    this also gives the modulus for a dominant complex pair).  Plain loops, no array expressions: numba
    compiles them in a fraction of the time (the same sums in the same order)."""
    n = ne
    span = np.empty((2, n), np.int64)  # each row's first and last nonzero column: the products skip the zeros
    for r in range(n):
        span[0, r], span[1, r] = n, -1
        for c in range(n):
            if J[r, c] != 0:
                span[0, r] = min(span[0, r], c)
                span[1, r] = c
    x = np.empty(n)
    nrm = 0.0
    for i in range(n):
        x[i] = 1.0 + 0.1 * ((i * 7919) % 13)  # fixed, generic start vector
        nrm += x[i] * x[i]
    nrm = np.sqrt(nrm)
    if nrm == 0:
        return 0.0
    for i in range(n):
        x[i] /= nrm
    y = np.empty(n)
    logsum = 0.0
    cnt = 0
    for it in range(30):
        nrm = 0.0
        for r in range(n):
            s = 0.0
            for c in range(span[0, r], span[1, r] + 1):
                s += J[r, c] * x[c]
            y[r] = s
            nrm += s * s
        nrm = np.sqrt(nrm)
        if nrm == 0.0 or not np.isfinite(nrm):
            return 0.0 if nrm == 0.0 else np.inf
        if it >= 15:
            logsum += np.log(nrm)
            cnt += 1
        for r in range(n):
            x[r] = y[r] / nrm
    return np.exp(logsum / cnt)


@generic_inline
def jacobian_spectral_radius(p, t, z, f0, ne):
    """Spectral radius of df/dz at (t, z) (f0 = f(t, z)), without counting the evaluations in the run's
    statistics: the fixed-step methods' stability probe."""
    n = z.shape[0]
    J = np.empty((n, n))
    scratch = np.zeros(1, STATS)
    fd_jacobian(p, t, z, f0, np.zeros(n), ne, J, scratch[0])
    return spectral_radius(J, ne)
