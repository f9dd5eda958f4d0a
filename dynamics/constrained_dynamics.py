"""Constrained forward and inverse dynamics: the KKT system of a closed-loop or coupled mechanism.

With the constraint rows of :mod:`dynamics.constraints` (phi, Phi_q = J, gamma = Phi_q_dot v) the lectures'
equations of a parallel mechanism are

    M a + C v + g = tau + J^T lambda,        J a + gamma = -(2 alpha J v + beta^2 phi)

(the right-hand side: Baumgarte's stabilisation phi_dd + 2 alpha phi_d + beta^2 phi = 0, zero without it).
Eliminating a with f = tau - C v - g (the lectures' formula):

    K = J M^-1 J^T (the Delassus matrix),   K lambda = -(J M^-1 f + gamma + 2 alpha J v + beta^2 phi),
    a = M^-1 (f + J^T lambda).

M comes from the CRBA and is factored M = L^T L with no fill-in (Featherstone 2008, sec. 6.5: L[k, c] != 0
only where coordinate c is k or an ancestor of k), so that with Y = (L^-T J^T)^T (m, nv): K = Y Y^T,
J M^-1 f = Y (L^-T f), a = L^-1 (L^-T f + Y^T lambda); C v + g from the RNEA at a = 0.  Measured
(benchmarks/constraints.py): the CRBA and a factor cost less than the O(n^2) articulated-body M^-1 of
:mod:`dynamics.minverse`, which the first version used; the L^T L factor rather than a dense Cholesky
because a branched tree's M is sparse (the Stewart platform's is block diagonal: 1.2 us against 1.8 us per
state, K 2 us against 4 us), at ~0.1 us more on a floating chain.

Redundant rows are normal (a planar loop closed by a 3-D point or hinge closure, a closure declared twice): K
is then singular, a stays unique, and lambda is the minimum-norm multiplier lambda = K^+ rhs.  A Cholesky
factor of K serves when its pivots stay above :data:`CHOLESKY_RTOL`; otherwise Cholesky with diagonal
pivoting stops at the rank (the pivots left below :data:`RANK_RTOL` times K's largest diagonal entry are the
round-off of exactly dependent rows, ~1e-16 relative) and the minimum-norm solution follows from the r x r
Gram matrix of the factor (:func:`_pinv_solve`): no eigen-decomposition, no allocation.  It equals K^+ rhs for
a right-hand side in K's range, which a closed loop's is (J M^-1 f and J v lie in J's range, and dependent
rows have dependent gamma and phi); the tests compare it with numpy's pinv(K) rhs and with the even split
of a closure declared twice, to 1e-9 relative.
lambda's rows and frames are those of :mod:`dynamics.constraints` (world axes, force on body a at its
anchor, torques, coupling forces).

Simulation hook (for :mod:`dynamics.simulation`; compiled, single state, no allocation).  With ``C, m = dynamics.constraints.arrays(model)`` (resolved once and kept
with the model) and one ``ws = _workspace(model.nbodies, model.nv, m)`` per thread:

* ``_constrained_accel_kernel(tree, C, gravity, q, v, tau, alpha, beta, ws, a_out, lam_out) -> int``: the
  right-hand side a = qdd (and lambda) in place of the ABA; -1 when fine, else the body whose joint makes M
  singular.  alpha, beta: Baumgarte gains (1/s), :data:`DEFAULT_BAUMGARTE` for a simulation, 0, 0 for none.
* ``_drift_kernel(tree, C, q, v, ws) -> (max |phi|, max |Phi_q v|)``: the position and velocity residuals, for
  ``constraint_drift`` in the report (their largest values over the run).
* ``_project_position_kernel(tree, C, q, ws, tol, max_iter, q_out) -> max |phi|`` then
  ``_project_velocity_kernel(tree, C, q_out, v, ws, v_out) -> int``: the optional projection onto the
  constraint manifold after an accepted step (positions by Gauss-Newton, velocities in the kinetic-energy
  metric).
"""

import numpy as np

from . import _core, checks
from ._numba import copy_into, helper, kernel
from .configuration import _integrate_q
from .constraints import arrays, _constraint_terms, core_constraints, run_core
from .constraints import _workspace as terms_workspace
from .errors import InputError
from .crba import _crba_into
from .crba import _workspace as crba_workspace
from .rnea import _rnea_terms
from .rnea import _workspace as rnea_workspace

#: pivots of K's pivoted Cholesky factor below this times K's largest diagonal entry are dependent rows
RANK_RTOL = 1e-12
#: a Cholesky pivot of K below this times K's largest diagonal entry sends the solve to the pivoted factor
CHOLESKY_RTOL = 1e-10
#: default Baumgarte gains of a simulation (1/s): a critically damped phi_dd + 2 alpha phi_d + beta^2 phi = 0
DEFAULT_BAUMGARTE = (10.0, 10.0)


@helper
def _workspace(nb, nv, m):
    """Scratch of one state: kinematics, CRBA, RNEA, then L (nv, nv; M = L^T L), J (m, nv), phi, gamma (m,),
    f (nv,), Y = (L^-T J^T)^T (m, nv), K (m, m), rhs (m,), an empty f_ext, K's Cholesky factor (m, m), the
    parent of each velocity coordinate (nv,), K's pivot order (m,) and an m-vector."""
    return (terms_workspace(nb, nv), crba_workspace(nb), rnea_workspace(nb), np.empty((nv, nv)),
            np.empty((m, nv)), np.empty(m), np.empty(m), np.empty(nv), np.empty((m, nv)), np.empty((m, m)),
            np.empty(m), np.zeros((0, 6)), np.empty((m, m)), np.empty(nv, np.int64), np.empty(m, np.int64),
            np.empty(m))


@kernel
def _dof_parents(tree, lam):
    """lam[k]: the velocity coordinate before k on the path to the root, -1 at the root (Featherstone's
    lambda over coordinates: the previous coordinate of a multi-coordinate joint, else the parent joint's last)."""
    parents, v_idx, nv_j = tree.parents, tree.v_idx, tree.nv_j
    for i in range(parents.shape[0]):
        p = parents[i]
        prev = v_idx[p] + nv_j[p] - 1 if p >= 0 else -1
        for k in range(v_idx[i], v_idx[i] + nv_j[i]):
            lam[k] = prev
            prev = k


@kernel
def _mass_factor(tree, q, ws, L, lam):
    """M(q) = L^T L, L lower triangular with L[k, c] != 0 only where c is k or an ancestor coordinate of k: the
    LTL factorisation of Featherstone 2008, sec. 6.5, Table 6.3, which a tree's M factors with no fill-in
    (M from the CRBA; lam from :func:`_dof_parents`).  Cost sum_k depth(k)^2 rather than nv^3 / 6.  Only the
    entries at (k, k) and (k, ancestor of k) are L; the others are left as they were (never read).  Returns -1,
    or the body whose joint has a non-positive pivot (M singular: the joint moves no mass)."""
    nv = L.shape[0]
    _crba_into(tree, q, ws, L)  # writes the entries of coordinate pairs on one path to the root, the only ones read
    _dof_parents(tree, lam)
    for k in range(nv - 1, -1, -1):
        d = L[k, k]
        if not d > 0.0:
            for i in range(tree.v_idx.shape[0]):
                if tree.v_idx[i] <= k < tree.v_idx[i] + tree.nv_j[i]:
                    return i
            return 0
        d = np.sqrt(d)
        L[k, k] = d
        i = lam[k]
        while i >= 0:
            L[k, i] /= d
            i = lam[i]
        i = lam[k]
        while i >= 0:
            j = i
            while j >= 0:
                L[i, j] -= L[k, i] * L[k, j]
                j = lam[j]
            i = lam[i]
    return -1


@kernel
def _ltl_solve_t(L, lam, x):
    """x = L^-T x in place (M^-1 = L^-1 L^-T; from the leaves to the root)."""
    for i in range(x.shape[0] - 1, -1, -1):
        x[i] /= L[i, i]
        j = lam[i]
        while j >= 0:
            x[j] -= L[i, j] * x[i]
            j = lam[j]


@kernel
def _ltl_solve(L, lam, x):
    """x = L^-1 x in place (from the root to the leaves)."""
    for i in range(x.shape[0]):
        y = x[i]
        j = lam[i]
        while j >= 0:
            y -= L[i, j] * x[j]
            j = lam[j]
        x[i] = y / L[i, i]


@kernel
def _delassus(L, lam, J, Y, K):
    """Y = (L^-T J^T)^T (m, nv; row r = L^-T J[r]) and K = Y Y^T = J M^-1 J^T (m, m)."""
    m, nv = Y.shape[0], Y.shape[1]
    for r in range(m):  # _ltl_solve_t on each row, written out (no views), skipping the zeros of sparse rows
        for k in range(nv):
            Y[r, k] = J[r, k]
        for i in range(nv - 1, -1, -1):
            y = Y[r, i] / L[i, i]
            Y[r, i] = y
            if y != 0.0:
                j = lam[i]
                while j >= 0:
                    Y[r, j] -= L[i, j] * y
                    j = lam[j]
    for r in range(m):
        for s in range(r, m):
            y = 0.0
            for k in range(nv):
                y += Y[r, k] * Y[s, k]
            K[r, s] = y
            K[s, r] = y


@kernel
def _cholesky(A, n, tol):
    """A[:n, :n] = L L^T in place (lower triangle, the upper one not read).  False when a pivot is <= tol."""
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= A[j, k] * A[j, k]
        if not d > tol:
            return False
        d = np.sqrt(d)
        A[j, j] = d
        for r in range(j + 1, n):
            y = A[r, j]
            for k in range(j):
                y -= A[r, k] * A[j, k]
            A[r, j] = y / d
    return True


@kernel
def _lower_solve(L, n, x):
    """x[:n] = L[:n, :n]^-1 x[:n] in place (forward substitution)."""
    for r in range(n):
        y = x[r]
        for k in range(r):
            y -= L[r, k] * x[k]
        x[r] = y / L[r, r]


@kernel
def _upper_solve(L, n, x):
    """x[:n] = L[:n, :n]^-T x[:n] in place (back substitution)."""
    for r in range(n - 1, -1, -1):
        y = x[r]
        for k in range(r + 1, n):
            y -= L[k, r] * x[k]
        x[r] = y / L[r, r]


@kernel
def _pinv_solve(K, rhs, rtol, x, L, piv, t):
    """x = K^+ rhs for a symmetric positive semidefinite K (the minimum-norm solution); returns the rank.  No
    allocation: L (m, m), piv (m,) int and t (m,) are scratch, K is overwritten when rows are dependent.

    Full-rank K (every Cholesky pivot above :data:`CHOLESKY_RTOL` times the largest diagonal entry): K = L L^T
    and two triangular solves.  Otherwise Cholesky with diagonal pivoting, P^T K P = L L^T with L (m, r),
    stopping where the largest pivot left is below rtol times K's largest diagonal entry (the dependent rows'
    round-off); then the minimum-norm solution of L^T y = z, L z = P^T rhs (its first r rows), y = L (L^T
    L)^-1 z, x = P y: K^+ rhs exactly for a right-hand side in K's range (a closed loop's rows are consistent),
    round-off otherwise."""
    m = K.shape[0]
    if m == 0:
        return 0
    dmax = 0.0
    for r in range(m):
        dmax = max(dmax, K[r, r])
    for r in range(m):
        copy_into(L[r], K[r])
    if dmax > 0.0 and _cholesky(L, m, CHOLESKY_RTOL * dmax):
        copy_into(x, rhs)
        _lower_solve(L, m, x)
        _upper_solve(L, m, x)
        return m
    rank = _pivoted_cholesky(K, rtol * dmax, L, piv)
    for r in range(rank):  # z = L1^-1 (P^T rhs)[:r] in t
        t[r] = rhs[piv[r]]
    _lower_solve(L, rank, t)
    for a in range(rank):  # G = L^T L (rank x rank, lower triangle) in K
        for b in range(a + 1):
            y = 0.0
            for r in range(m):
                y += L[r, a] * L[r, b]
            K[a, b] = y
    _cholesky(K, rank, 0.0)  # positive definite: L's r columns are independent
    _lower_solve(K, rank, t)  # w = G^-1 z
    _upper_solve(K, rank, t)
    for r in range(m):  # x = P L w
        y = 0.0
        for a in range(rank):
            y += L[r, a] * t[a]
        x[piv[r]] = y
    return rank


@kernel
def _pivoted_cholesky(K, tol, L, piv):
    """P^T K P = L L^T with diagonal pivoting (Golub & Van Loan, Algorithm 4.2.4 as an outer product):
    columns of L (m, m) beyond the returned rank r are left zero; stops when the largest pivot left is <= tol.
    piv[i] is the row of K at position i.  L starts as a copy of K; K is not changed."""
    m = K.shape[0]
    L[:, :] = K
    for i in range(m):
        piv[i] = i
    for j in range(m):
        p = j
        for i in range(j + 1, m):
            if L[i, i] > L[p, p]:
                p = i
        if not L[p, p] > tol:
            for i in range(m):  # the trailing block is the dependent rows' round-off: dropped
                for c in range(j, m):
                    L[i, c] = 0.0
            return j
        if p != j:  # swap rows and columns j and p (the whole matrix: the trailing block is kept symmetric)
            piv[j], piv[p] = piv[p], piv[j]
            for c in range(m):
                L[j, c], L[p, c] = L[p, c], L[j, c]
            for r in range(m):
                L[r, j], L[r, p] = L[r, p], L[r, j]
        d = np.sqrt(L[j, j])
        L[j, j] = d
        for r in range(j + 1, m):
            L[r, j] /= d
        for r in range(j + 1, m):
            for c in range(j + 1, m):
                L[r, c] -= L[r, j] * L[c, j]
        for c in range(j + 1, m):
            L[j, c] = 0.0
    return m


@kernel
def _constrained_accel_kernel(tree, C, gravity, q, v, tau, alpha, beta, ws, a_out, lam_out):
    """One state: a_out (nv,) and lam_out (m,) of the KKT system (module docstring) with Baumgarte gains alpha,
    beta (1/s; 0, 0 for none).  ws = _workspace(nb, nv, m), reused across calls of one
    thread.  Returns -1, or the index of a body whose joint makes M singular (then the outputs are not valid).
    The single-state entry for a simulation's right-hand side: it allocates nothing."""
    tws, cws, rws, LM, J, phi, gamma, f, Y, K, rhs, no_forces, LK, lam, piv, t = ws
    nv, m = f.shape[0], phi.shape[0]
    status = _mass_factor(tree, q, cws, LM, lam)
    if status >= 0:
        return status
    _rnea_terms(tree, q, v, v, gravity, no_forces, rws, f, True, False)  # f = C v + g
    for k in range(nv):
        f[k] = tau[k] - f[k]
    _ltl_solve_t(LM, lam, f)  # f = L^-T (tau - C v - g)
    _constraint_terms(tree, C, q, v, True, True, tws, phi, J, gamma)
    _delassus(LM, lam, J, Y, K)
    for r in range(m):  # rhs = -(J M^-1 f + gamma + 2 alpha J v + beta^2 phi), J M^-1 f = Y L^-T f
        x = gamma[r] + beta * beta * phi[r]
        for c in range(nv):
            x += Y[r, c] * f[c] + 2.0 * alpha * J[r, c] * v[c]
        rhs[r] = -x
    _pinv_solve(K, rhs, RANK_RTOL, lam_out, LK, piv, t)
    for k in range(nv):  # a = L^-1 (L^-T f + Y^T lambda)
        a_out[k] = f[k]
    for r in range(m):
        for k in range(nv):
            a_out[k] += Y[r, k] * lam_out[r]
    _ltl_solve(LM, lam, a_out)
    return -1


@kernel
def _drift_kernel(tree, C, q, v, ws):
    """(max |phi(q)|, max |Phi_q v|): the position and velocity residuals of one state (ws = _workspace)."""
    tws, _, _, _, J, phi, gamma, _, _, _, _, _, _, _, _, _ = ws
    _constraint_terms(tree, C, q, v, True, False, tws, phi, J, gamma)
    pos, vel = 0.0, 0.0
    for r in range(phi.shape[0]):
        pos = max(pos, abs(phi[r]))
        x = 0.0
        for c in range(v.shape[0]):
            x += J[r, c] * v[c]
        vel = max(vel, abs(x))
    return pos, vel


@kernel
def _project_velocity_kernel(tree, C, q, v, ws, v_out):
    """v_out = v - M^-1 J^T K^+ J v: the velocity closest to v in the kinetic-energy metric with J v_out = 0
    (what an impulse along the constraints does).  Returns -1 or a body whose joint makes M singular."""
    tws, cws, _, LM, J, phi, gamma, f, Y, K, rhs, _, LK, lam, piv, t = ws
    nv, m = v.shape[0], phi.shape[0]
    status = _mass_factor(tree, q, cws, LM, lam)
    if status >= 0:
        return status
    _constraint_terms(tree, C, q, v, True, False, tws, phi, J, gamma)
    _delassus(LM, lam, J, Y, K)
    for r in range(m):
        x = 0.0
        for c in range(nv):
            x += J[r, c] * v[c]
        rhs[r] = -x
    _pinv_solve(K, rhs, RANK_RTOL, gamma, LK, piv, t)
    f[:] = 0.0
    for r in range(m):  # M^-1 J^T mu = L^-1 Y^T mu
        for k in range(nv):
            f[k] += Y[r, k] * gamma[r]
    _ltl_solve(LM, lam, f)
    for k in range(nv):
        v_out[k] = v[k] + f[k]
    return -1


@kernel
def _project_position_kernel(tree, C, q, ws, tol, max_iter, q_out):
    """q_out = q moved onto phi = 0 by Gauss-Newton with minimum-norm steps, q_{k+1} = q_k (+) (-J^+ phi), at
    most max_iter steps (near the manifold, after an accepted step, it converges quadratically).  Returns max
    |phi(q_out)|; above tol the projection failed (the caller keeps q and reports it)."""
    tws, _, _, _, J, phi, gamma, f, _, _, _, _, _, _, _, _ = ws
    copy_into(q_out, q)
    err = 0.0
    for it in range(max_iter + 1):
        _constraint_terms(tree, C, q_out, f, True, False, tws, phi, J, gamma)
        err = 0.0
        for r in range(phi.shape[0]):
            err = max(err, abs(phi[r]))
        if err <= tol or it == max_iter:
            break
        dq = np.linalg.lstsq(J, phi, rcond=1e-12)[0]
        copy_into(q_out, _integrate_q(tree, q_out, dq, -1.0))
    return err


# -- public entry points -----------------------------------------------------------------------------------------
class _Failed(Exception):
    def __init__(self, state, code):
        self.state, self.code = state, code


def _singular(model, what, e):
    return InputError(f"{what}: the mass matrix is singular at joint {model.joint_names[e.code]!r}: it moves no "
                      f"mass or inertia (lock it with dynamics.lock_joints, or add mass below it)")


def baumgarte_gains(baumgarte):
    """(alpha, beta) from None (no stabilisation) or a pair of finite numbers >= 0 (1/s)."""
    if baumgarte is None:
        return 0.0, 0.0
    try:
        alpha, beta = baumgarte
    except (TypeError, ValueError):
        raise InputError(f"baumgarte: expected None or (alpha, beta) in 1/s, got {baumgarte!r}") from None
    return (checks.real_number("baumgarte alpha", alpha, lo=0.0), checks.real_number("baumgarte beta", beta, lo=0.0))


def constrained_forward_dynamics(model, q, v, tau, *, baumgarte=None, gravity=None):
    """Accelerations and multipliers of a constrained model: (a, lam), (nv,) and (m,), or (B, nv) and (B, m).

    Solves M a + C v + g = tau + Phi_q^T lam with Phi_q a + Phi_q_dot v = -(2 alpha Phi_q v + beta^2 phi)
    (``baumgarte=(alpha, beta)`` in 1/s; None: no stabilisation).  lam: minimum-norm multipliers in physical
    units, the rows and frames of :mod:`dynamics.constraints` (world axes; force on frame_a's body at its
    anchor [N], torques [N m], coupling generalised forces).  A model without constraints gives the ABA's a.
    The solve is the core's (``core/constrained_dynamics.cpp``).
    """
    alpha, beta = baumgarte_gains(baumgarte)
    if gravity is None:  # one state: one core call, which checks q, v and tau itself
        try:
            out = _core.constrained_forward_dynamics(model.core, core_constraints(model), q, v, tau, alpha, beta)
            if out is not None:
                return out
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    checks.check_model(model)
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    m = arrays(model)[1]
    out = np.empty((B, model.nv + m))
    failed, body = run_core(_core.constrained_forward_dynamics_batch, model, Q, V, T,
                            checks.gravity_vector(model, gravity), alpha, beta, out=out)
    if failed >= 0:
        raise _singular(model, "constrained forward dynamics", _Failed(failed, body))
    a, lam = out[:, :model.nv], out[:, model.nv:]
    return (a, lam) if batched else (a[0], lam[0])


def project_velocity(model, q, v):
    """The velocity closest to v (kinetic-energy metric) that satisfies Phi_q v = 0: (nv,) or (B, nv)."""
    checks.check_model(model)
    Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = np.empty((B, model.nv))
    failed, body = run_core(_core.project_velocity_batch, model, Q, V, out=out)
    if failed >= 0:
        raise _singular(model, "project_velocity", _Failed(failed, body))
    return out if batched else out[0]


def _actuated_mask(model, actuated):
    if isinstance(actuated, str) or not hasattr(actuated, "__iter__"):
        raise InputError(f"actuated: expected a list of joint names, got {actuated!r}")
    mask = np.zeros(model.nv)
    for name in actuated:
        if not isinstance(name, str):
            raise InputError(f"actuated: expected joint names (str), got {name!r}")
        mask[model.v_slice(name)] = 1.0
    return mask


def constrained_inverse_dynamics(model, q, v, a, *, actuated, gravity=None):
    """Torques of the ``actuated`` joints (names) that produce the motion (q, v, a) of a constrained model: tau
    (nv,) or (B, nv), zero at passive joints, with M a + C v + g = tau + Phi_q^T lam for some lam.

    With more actuators than the mechanism's mobility, tau is the minimum-norm choice.  Raises InputError when
    a violates the constraints (Phi_q a + Phi_q_dot v != 0) or when the actuated joints cannot produce it (too
    few, or placed where the loops take their torque), naming the state.
    """
    Q, (V, A), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("a", a, model.nv)))
    mask = _actuated_mask(model, actuated)
    out = np.empty((B, model.nv))
    failed, code = run_core(_core.constrained_inverse_dynamics_batch, model, Q, V, A,
                            checks.gravity_vector(model, gravity), mask, out=out)
    if failed >= 0:
        where = f" (state {failed})" if batched else ""
        if code == 1:
            raise InputError(f"a{where}: violates the constraints (Phi_q a + Phi_q_dot v != 0); constrained "
                             f"motions satisfy them, e.g. the a of constrained_forward_dynamics")
        names = [model.joint_names[i] for i in range(model.nbodies) if mask[model.v_index[i]]]
        raise InputError(f"actuated{where}: the joints {names} cannot produce this motion of the constrained "
                         f"mechanism (too few actuators for its {model.info.get('constraints', {}).get('mobility', '?')}"
                         f" degrees of freedom, or torques the loops absorb); actuate other joints")
    return out if batched else out[0]
