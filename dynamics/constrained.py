"""Constrained forward and inverse dynamics: the KKT system of a closed-loop or coupled mechanism.

With the constraint rows of :mod:`dynamics.constraints` (phi, Phi_q = J, gamma = Phi_q_dot v) the lectures'
equations of a parallel mechanism are

    M a + C v + g = tau + J^T lambda,        J a + gamma = -(2 alpha J v + beta^2 phi)

(the right-hand side: Baumgarte's stabilisation phi_dd + 2 alpha phi_d + beta^2 phi = 0, zero without it).
Eliminating a with f = tau - C v - g (the lectures' formula):

    K = J M^-1 J^T (the Delassus matrix),   K lambda = -(J M^-1 f + gamma + 2 alpha J v + beta^2 phi),
    a = M^-1 (f + J^T lambda).

M comes from the CRBA and is factored M = L L^T in the kernel (Y = L^-1 J^T, K = Y^T Y, a = L^-T (L^-1 f + Y
lambda)); C v + g from the RNEA at a = 0.  Measured (benchmarks/constraints.py): on the Cassie-like leg the
CRBA and a Cholesky cost less than the O(n^2) articulated-body M^-1 of :mod:`dynamics.minverse`, which the
first version used.  Redundant rows are normal (a planar loop closed by a 3-D point or hinge
closure): K is then singular, a stays unique, and lambda is the minimum-norm multiplier, lambda = K^+ rhs,
with K^+ from K's eigen-decomposition keeping eigenvalues above :data:`RANK_RTOL` times the largest (the
discarded ones are round-off of exactly dependent rows, ~1e-16 relative).  lambda's rows and frames are those
of :mod:`dynamics.constraints` (world axes, force on body a at its anchor, torques, coupling forces).

Simulation hook (for :mod:`dynamics.simulation`; compiled, single state, no allocation except the eigen-
decomposition of dependent rows).  With ``C, m = dynamics.constraints.arrays(model)`` (resolved once and kept
with the model) and one ``ws = workspace(model.nbodies, model.nv, m)`` per thread:

* ``constrained_accel_kernel(tree, C, gravity, q, v, tau, alpha, beta, ws, a_out, lam_out) -> int``: the
  right-hand side a = qdd (and lambda) in place of the ABA; -1 when fine, else the body whose joint makes M
  singular.  alpha, beta: Baumgarte gains (1/s), :data:`DEFAULT_BAUMGARTE` for a simulation, 0, 0 for none.
* ``drift_kernel(tree, C, q, v, ws) -> (max |phi|, max |Phi_q v|)``: the position and velocity residuals, for
  ``constraint_drift`` in the report (their largest values over the run).
* ``project_position_kernel(tree, C, q, ws, tol, max_iter, q_out) -> max |phi|`` then
  ``project_velocity_kernel(tree, C, q_out, v, ws, v_out) -> int``: the optional projection onto the
  constraint manifold after an accepted step (positions by Gauss-Newton, velocities in the kinetic-energy
  metric).
"""

import numpy as np

from . import checks
from ._numba import Kernel, copy_into, kernel
from .configuration import integrate_q
from .constraints import arrays, constraint_terms
from .constraints import workspace as terms_workspace
from .checks import config_ok, vector_ok
from .errors import InputError
from .model import Model
from .crba import crba_into
from .crba import workspace as crba_workspace
from .parallel import run_chunks
from .rnea import rnea_terms
from .rnea import workspace as rnea_workspace

#: eigenvalues of K (and singular values in the inverse dynamics) below this times the largest are dependent rows
RANK_RTOL = 1e-12
#: a Cholesky pivot of K below this times K's largest diagonal entry sends the solve to the eigen-decomposition
CHOLESKY_RTOL = 1e-10
#: default Baumgarte gains of a simulation (1/s): a critically damped phi_dd + 2 alpha phi_d + beta^2 phi = 0
DEFAULT_BAUMGARTE = (10.0, 10.0)


@kernel
def workspace(nb, nv, m):
    """Scratch of one state: kinematics, CRBA, RNEA, then L (nv, nv; M's Cholesky factor), J (m, nv), phi,
    gamma (m,), f (nv,), Y = L^-1 J^T (nv, m), K (m, m), rhs (m,), an empty f_ext, K's Cholesky factor."""
    return (terms_workspace(nb, nv), crba_workspace(nb), rnea_workspace(nb), np.empty((nv, nv)),
            np.empty((m, nv)), np.empty(m), np.empty(m), np.empty(nv), np.empty((nv, m)), np.empty((m, m)),
            np.empty(m), np.zeros((0, 6)), np.empty((m, m)))


@kernel
def mass_factor(tree, q, ws, L):
    """L = the Cholesky factor of M(q) (lower triangle; M from the CRBA).  Returns -1, or the body whose joint
    has a non-positive pivot (M singular: the joint moves no mass)."""
    nv = L.shape[0]
    L[:, :] = 0.0
    crba_into(tree, q, ws, L)
    for j in range(nv):
        d = L[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            for i in range(tree.v_idx.shape[0]):
                if tree.v_idx[i] <= j < tree.v_idx[i] + tree.nv_j[i]:
                    return i
            return 0
        d = np.sqrt(d)
        L[j, j] = d
        for r in range(j + 1, nv):
            y = L[r, j]
            for k in range(j):
                y -= L[r, k] * L[j, k]
            L[r, j] = y / d
    return -1


@kernel
def lower_solve(L, x):
    """x = L^-1 x in place (forward substitution)."""
    for r in range(x.shape[0]):
        y = x[r]
        for k in range(r):
            y -= L[r, k] * x[k]
        x[r] = y / L[r, r]


@kernel
def upper_solve(L, x):
    """x = L^-T x in place (back substitution)."""
    for r in range(x.shape[0] - 1, -1, -1):
        y = x[r]
        for k in range(r + 1, x.shape[0]):
            y -= L[k, r] * x[k]
        x[r] = y / L[r, r]


@kernel
def delassus(L, J, Y, K):
    """Y = L^-1 J^T (nv, m) and K = Y^T Y = J M^-1 J^T (m, m)."""
    nv, m = Y.shape[0], Y.shape[1]
    for r in range(m):
        for k in range(nv):
            y = J[r, k]
            for c in range(k):
                y -= L[k, c] * Y[c, r]
            Y[k, r] = y / L[k, k]
    for r in range(m):
        for s in range(r, m):
            y = 0.0
            for k in range(nv):
                y += Y[k, r] * Y[k, s]
            K[r, s] = y
            K[s, r] = y


@kernel
def pinv_solve(K, rhs, rtol, x, L):
    """x = K^+ rhs for a symmetric positive semidefinite K (minimum-norm least squares); returns the rank.

    Full-rank K (every Cholesky pivot above :data:`CHOLESKY_RTOL` times the largest diagonal entry): a
    Cholesky solve in L (m, m scratch), no allocation.  Otherwise K's eigen-decomposition, eigenvalues above
    rtol times the largest kept (the dependent rows' round-off is dropped)."""
    m = K.shape[0]
    if m == 0:
        return 0
    dmax = 0.0
    for r in range(m):
        dmax = max(dmax, K[r, r])
    full = dmax > 0.0
    for j in range(m):
        if not full:
            break
        d = K[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if d <= CHOLESKY_RTOL * dmax:
            full = False
            break
        d = np.sqrt(d)
        L[j, j] = d
        for r in range(j + 1, m):
            y = K[r, j]
            for k in range(j):
                y -= L[r, k] * L[j, k]
            L[r, j] = y / d
    if full:
        for r in range(m):  # L y = rhs, then L^T x = y
            y = rhs[r]
            for k in range(r):
                y -= L[r, k] * x[k]
            x[r] = y / L[r, r]
        for r in range(m - 1, -1, -1):
            y = x[r]
            for k in range(r + 1, m):
                y -= L[k, r] * x[k]
            x[r] = y / L[r, r]
        return m
    w, E = np.linalg.eigh(K)
    cut = rtol * max(w[m - 1], 0.0)
    x[:] = 0.0
    rank = 0
    for k in range(m):
        if w[k] > cut and w[k] > 0.0:
            rank += 1
            c = 0.0
            for r in range(m):
                c += E[r, k] * rhs[r]
            c /= w[k]
            for r in range(m):
                x[r] += c * E[r, k]
    return rank


@kernel
def constrained_accel_kernel(tree, C, gravity, q, v, tau, alpha, beta, ws, a_out, lam_out):
    """One state: a_out (nv,) and lam_out (m,) of the KKT system (module docstring) with Baumgarte gains alpha,
    beta (1/s; 0, 0 for none).  ws = workspace(nb, nv, m), reused across calls of one thread.  Returns -1, or
    the index of a body whose joint makes M singular (then the outputs are not valid).  The single-state entry
    for a simulation's right-hand side: it allocates only inside the m x m eigen-decomposition."""
    tws, cws, rws, LM, J, phi, gamma, f, Y, K, rhs, no_forces, LK = ws
    nv, m = f.shape[0], phi.shape[0]
    status = mass_factor(tree, q, cws, LM)
    if status >= 0:
        return status
    rnea_terms(tree, q, v, v, gravity, no_forces, rws, f, True, False)  # f = C v + g
    for k in range(nv):
        f[k] = tau[k] - f[k]
    lower_solve(LM, f)  # f = L^-1 (tau - C v - g)
    constraint_terms(tree, C, q, v, True, True, tws, phi, J, gamma)
    delassus(LM, J, Y, K)
    for r in range(m):  # rhs = -(J M^-1 f + gamma + 2 alpha J v + beta^2 phi), J M^-1 f = Y^T L^-1 f
        x = gamma[r] + beta * beta * phi[r]
        for c in range(nv):
            x += Y[c, r] * f[c] + 2.0 * alpha * J[r, c] * v[c]
        rhs[r] = -x
    pinv_solve(K, rhs, RANK_RTOL, lam_out, LK)
    for k in range(nv):  # a = L^-T (L^-1 f + Y lambda)
        x = f[k]
        for r in range(m):
            x += Y[k, r] * lam_out[r]
        a_out[k] = x
    upper_solve(LM, a_out)
    return -1


@kernel
def constrained_fd_batch(tree, Q, V, T, C, gravity, alpha, beta, out, status):
    """out[b] = [a; lambda] of state b (V and T may have one row)."""
    nb, nv, m = tree.parents.shape[0], tree.S.shape[0], out.shape[1] - tree.S.shape[0]
    ws = workspace(nb, nv, m)
    lv, lt = V.shape[0] - 1, T.shape[0] - 1
    for b in range(Q.shape[0]):
        status[b] = constrained_accel_kernel(tree, C, gravity, Q[b], V[min(b, lv)], T[min(b, lt)], alpha, beta,
                                             ws, out[b, :nv], out[b, nv:])


@kernel
def constrained_fd_single(tree, C, gravity, q, v, tau, alpha, beta):
    """One state with its inputs checked in the same compiled call: (a, lam, status); status -2: a non-finite
    input or a zero quaternion (the general path then says which), else as constrained_accel_kernel."""
    nb, nv, m = tree.parents.shape[0], tree.S.shape[0], C_rows(C)
    a, lam = np.empty(nv), np.empty(m)
    if not (config_ok(tree, q.shape[0], q) and vector_ok(v, nv) and vector_ok(tau, nv)):
        return a, lam, -2
    return a, lam, constrained_accel_kernel(tree, C, gravity, q, v, tau, alpha, beta, workspace(nb, nv, m), a, lam)


@kernel
def drift_kernel(tree, C, q, v, ws):
    """(max |phi(q)|, max |Phi_q v|): the position and velocity residuals of one state (ws = workspace)."""
    tws, _, _, _, J, phi, gamma, _, _, _, _, _, _ = ws
    constraint_terms(tree, C, q, v, True, False, tws, phi, J, gamma)
    pos, vel = 0.0, 0.0
    for r in range(phi.shape[0]):
        pos = max(pos, abs(phi[r]))
        x = 0.0
        for c in range(v.shape[0]):
            x += J[r, c] * v[c]
        vel = max(vel, abs(x))
    return pos, vel


@kernel
def project_velocity_kernel(tree, C, q, v, ws, v_out):
    """v_out = v - M^-1 J^T K^+ J v: the velocity closest to v in the kinetic-energy metric with J v_out = 0
    (what an impulse along the constraints does).  Returns -1 or a body whose joint makes M singular."""
    tws, cws, _, LM, J, phi, gamma, f, Y, K, rhs, _, LK = ws
    nv, m = v.shape[0], phi.shape[0]
    status = mass_factor(tree, q, cws, LM)
    if status >= 0:
        return status
    constraint_terms(tree, C, q, v, True, False, tws, phi, J, gamma)
    delassus(LM, J, Y, K)
    for r in range(m):
        x = 0.0
        for c in range(nv):
            x += J[r, c] * v[c]
        rhs[r] = -x
    pinv_solve(K, rhs, RANK_RTOL, gamma, LK)
    for k in range(nv):  # M^-1 J^T mu = L^-T Y mu
        x = 0.0
        for r in range(m):
            x += Y[k, r] * gamma[r]
        f[k] = x
    upper_solve(LM, f)
    for k in range(nv):
        v_out[k] = v[k] + f[k]
    return -1


@kernel
def project_position_kernel(tree, C, q, ws, tol, max_iter, q_out):
    """q_out = q moved onto phi = 0 by Gauss-Newton with minimum-norm steps, q_{k+1} = q_k (+) (-J^+ phi), at
    most max_iter steps (near the manifold, after an accepted step, it converges quadratically).  Returns max
    |phi(q_out)|; above tol the projection failed (the caller keeps q and reports it)."""
    tws, _, _, _, J, phi, gamma, f, _, _, _, _, _ = ws
    copy_into(q_out, q)
    err = 0.0
    for it in range(max_iter + 1):
        constraint_terms(tree, C, q_out, f, True, False, tws, phi, J, gamma)
        err = 0.0
        for r in range(phi.shape[0]):
            err = max(err, abs(phi[r]))
        if err <= tol or it == max_iter:
            break
        dq = np.linalg.lstsq(J, phi, rcond=1e-12)[0]
        q_out[:] = integrate_q(tree, q_out, dq, -1.0)
    return err


@kernel
def project_batch(tree, Q, V, C, out, status):
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    ws = workspace(nb, nv, C_rows(C))
    lv = V.shape[0] - 1
    for b in range(Q.shape[0]):
        status[b] = project_velocity_kernel(tree, C, Q[b], V[min(b, lv)], ws, out[b])


@kernel
def C_rows(C):
    """m, the number of constraint rows."""
    n = C.kind.shape[0]
    if n == 0:
        return 0
    k = C.kind[n - 1]
    return C.row[n - 1] + (3 if k == 0 else 6 if k == 1 else 5 if k == 2 else 1)


# -- inverse dynamics --------------------------------------------------------------------------------------------

@kernel
def constrained_id_kernel(tree, C, gravity, q, v, a, actuated, ws, tau_out):
    """tau_out (nv,) with zeros at passive coordinates such that M a + C v + g = tau + J^T lambda for some
    lambda.  ``actuated`` (nv,) is 1.0 at actuated coordinates.  Returns 0 (done), 1 (a violates the
    constraints: J a + gamma != 0) or 2 (the actuated coordinates cannot produce this motion)."""
    tws, _, rws, _, J, phi, gamma, f, _, _, _, no_forces, _ = ws
    nv, m = f.shape[0], phi.shape[0]
    rnea_terms(tree, q, v, a, gravity, no_forces, rws, f, True, True)  # f = M a + C v + g
    constraint_terms(tree, C, q, v, True, True, tws, phi, J, gamma)
    scale = 1.0
    for r in range(m):
        x = gamma[r]
        s = abs(gamma[r])
        for c in range(nv):
            x += J[r, c] * a[c]
            s += abs(J[r, c] * a[c])
        if abs(x) > 1e-8 * max(s, 1e-3):
            return 1
    # N^T: the null space of J (the motions the loops allow); N^T (S_act tau) = N^T f decides tau
    NT = np.eye(nv)
    if m > 0:
        _, sv, Vt = np.linalg.svd(J)
        rank = 0
        for k in range(sv.shape[0]):
            if sv[k] > 1e-9 * sv[0]:
                rank += 1
        NT = np.ascontiguousarray(Vt[rank:, :])
    A = NT * actuated.reshape(1, nv)  # N^T S_act (k, nv), passive columns zero
    rhs = NT @ f
    tau = np.zeros(nv)
    if A.shape[0] > 0:
        tau = np.linalg.lstsq(A, rhs)[0]
    res, s = 0.0, 0.0
    Af = A @ tau
    for k in range(rhs.shape[0]):
        res = max(res, abs(Af[k] - rhs[k]))
        s = max(s, abs(rhs[k]))
    for c in range(nv):
        tau_out[c] = tau[c] * actuated[c]
        s = max(s, abs(f[c]))
    if res > 1e-8 * max(s, 1e-6):
        return 2
    return 0


@kernel
def constrained_id_batch(tree, Q, V, A, C, gravity, actuated, out, status):
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    ws = workspace(nb, nv, C_rows(C))
    lv, la = V.shape[0] - 1, A.shape[0] - 1
    for b in range(Q.shape[0]):
        status[b] = constrained_id_kernel(tree, C, gravity, Q[b], V[min(b, lv)], A[min(b, la)], actuated, ws,
                                          out[b])


# -- public entry points -----------------------------------------------------------------------------------------
class _Failed(Exception):
    def __init__(self, state, code):
        self.state, self.code = state, code


class _Checked:
    """A batch kernel whose last argument is a per-state status (-1 or 0: fine), for run_chunks."""

    def __init__(self, kernel, ok):
        self.kernel, self.ok = Kernel(kernel), ok

    def __call__(self, tree, *args):
        status = np.empty(args[-1].shape[0], np.int64)
        self.kernel(tree, *args, status)
        bad = np.flatnonzero(status != self.ok)
        if bad.size:
            raise _Failed(int(bad[0]), int(status[bad[0]]))


_fd_batch = _Checked(constrained_fd_batch, -1)
_fd_single = Kernel(constrained_fd_single)
_project_batch = _Checked(project_batch, -1)
_id_batch = _Checked(constrained_id_batch, 0)


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
    """
    alpha, beta = baumgarte_gains(baumgarte)
    if (gravity is None and type(model) is Model and checks.is_state(q, model.nq) and checks.is_state(v, model.nv)
            and checks.is_state(tau, model.nv)):  # one state: checked and solved in one compiled call
        a, lam, status = _fd_single(model.tree, arrays(model)[0], model.gravity, q, v, tau, alpha, beta)
        if status == -1:
            return a, lam
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    C, m = arrays(model)
    out = np.empty((B, model.nv + m))
    try:
        run_chunks(_fd_batch, model.tree, (Q, V, T), (C, checks.gravity_vector(model, gravity), alpha, beta), out)
    except _Failed as e:
        raise _singular(model, "constrained forward dynamics", e) from None
    a, lam = out[:, :model.nv], out[:, model.nv:]
    return (a, lam) if batched else (a[0], lam[0])


def project_velocity(model, q, v):
    """The velocity closest to v (kinetic-energy metric) that satisfies Phi_q v = 0: (nv,) or (B, nv)."""
    Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    C, _ = arrays(model)
    out = np.empty((B, model.nv))
    try:
        run_chunks(_project_batch, model.tree, (Q, V), (C,), out)
    except _Failed as e:
        raise _singular(model, "project_velocity", e) from None
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
    C, _ = arrays(model)
    out = np.empty((B, model.nv))
    try:
        run_chunks(_id_batch, model.tree, (Q, V, A), (C, checks.gravity_vector(model, gravity), mask), out)
    except _Failed as e:
        where = f" (state {e.state})" if batched else ""
        if e.code == 1:
            raise InputError(f"a{where}: violates the constraints (Phi_q a + Phi_q_dot v != 0); constrained "
                             f"motions satisfy them, e.g. the a of constrained_forward_dynamics") from None
        names = [model.joint_names[i] for i in range(model.nbodies) if mask[model.v_index[i]]]
        raise InputError(f"actuated{where}: the joints {names} cannot produce this motion of the constrained "
                         f"mechanism (too few actuators for its {model.info.get('constraints', {}).get('mobility', '?')}"
                         f" degrees of freedom, or torques the loops absorb); actuate other joints") from None
    return out if batched else out[0]
