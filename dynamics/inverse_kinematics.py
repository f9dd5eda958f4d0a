"""Inverse kinematics by damped least squares (resolved motion rate control made robust: Nakamura & Hanafusa
1986, Wampler 1986; the damping adapted as in Levenberg-Marquardt).

The error of frame f at q towards the target pose (R_d, p_d), in the local_world_aligned reference of
:func:`dynamics.frame_jacobian` (world axes at the frame origin):

    e = [p_d - p(q);  log(R_d R(q)^T)]       (only the first 3 rows with position_only)

Each iteration solves (J J^T + mu 1) y = e, steps dq = J^T y along the configuration manifold
(:func:`dynamics.integrate`, so a free-flyer's quaternion stays unit) and, when asked, keeps joints within their
limits: a joint at a limit that the step would push further out is frozen (its column of J dropped) and the
step solved again; what still overshoots is clamped (a projected step).  A step that does not reduce |e| is refused and mu grows tenfold; an accepted one
lowers mu tenfold, never below damping^2.  Near the solution the log's Jacobian is 1 + O(|e|), so the
iteration converges fast; far from it, or near a singularity, the damping keeps steps bounded.

It stops when |e| < tol (converged), after max_iter iterations, or when no step reduces |e| any more (mu
above 1e12, or a relative gain below 1e-12): stalled, e.g. at an unreachable target, where q is then the
closest pose this start leads to.  Unreachable targets
are reported, not raised.
"""

import numpy as np

from . import checks
from ._numba import borrow, keep_alive, kernel
from .configuration import _integrate_q
from .errors import InputError
from .jacobians import _jacobian_into
from .joints import _joint_limited
from .kinematics import LOCAL_WORLD_ALIGNED
from .parallel import run_chunks
from .spatial import matmul, _rotation_log, _spd_inverse, transpose

CONVERGED, MAX_ITER, STALLED = 0, 1, 2
STATUS = ("converged", "max_iter", "stalled")
#: the damping mu beyond which no step is tried any more
MAX_MU = 1e12


@kernel
def _error(Rd, pd, R, p, e):
    """e = [p_d - p; log(R_d R^T)]; returns (|position error|, |orientation error|)."""
    e[0], e[1], e[2] = pd[0] - p[0], pd[1] - p[1], pd[2] - p[2]
    e[3], e[4], e[5] = _rotation_log(matmul(Rd, transpose(R)))
    return (np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]), np.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5]))


@kernel
def _clamp(tree, lower, upper, q):
    for i in range(tree.jtype.shape[0]):
        if _joint_limited(tree, i):
            k, kq = tree.v_idx[i], tree.q_idx[i]
            q[kq] = min(max(q[kq], lower[k]), upper[k])


@kernel
def _dls_step(J, free, e, r, mu, A, Ainv, scratch, y, dq):
    """dq = F J^T (J F J^T + mu 1)^-1 e over the first r rows, F = diag(free).  False if not solvable."""
    nv = J.shape[1]
    for a in range(r):
        for c in range(a, r):
            x = mu if a == c else 0.0
            for k in range(nv):
                x += J[a, k] * free[k] * J[c, k]
            A[a, c] = x
            A[c, a] = x
    if not _spd_inverse(A, r, Ainv, 0, scratch):
        return False
    for a in range(r):
        x = 0.0
        for c in range(r):
            x += Ainv[0, a, c] * e[c]
        y[a] = x
    for k in range(nv):
        x = 0.0
        for a in range(r):
            x += J[a, k] * y[a]
        dq[k] = free[k] * x
    return True


@kernel
def _freeze_blocked(tree, lower, upper, q, dq, free):
    """Freeze (free = 0) each 1-dof joint at a limit that dq pushes further out; True if any was frozen."""
    frozen = False
    for i in range(tree.jtype.shape[0]):
        if _joint_limited(tree, i):
            k, kq = tree.v_idx[i], tree.q_idx[i]
            if free[k] != 0.0 and ((q[kq] <= lower[k] and dq[k] < 0.0) or (q[kq] >= upper[k] and dq[k] > 0.0)):
                free[k] = 0.0
                frozen = True
    return frozen


@kernel
def _ik_batch(model_tree, Q0, T, model_frames, f, r, tol, max_iter, damping, limits, lower, upper, out):
    """out[b] = (q solving the IK from Q0[b] towards T[b], status, iterations, residual, position error,
    orientation error); T has B rows or one."""
    # borrowed: _jacobian_into takes the arrays out of the tuples per body and per step: no reference counts
    tree, frames = borrow(model_tree), borrow(model_frames)
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    path, oR, op = np.empty(nb, np.int64), np.empty((nb, 3, 3)), np.empty((nb, 3))
    J, Jt = np.zeros((6, nv)), np.zeros((6, nv))
    e, et, y = np.empty(6), np.empty(6), np.empty(6)
    A, Ainv, scratch = np.empty((6, 6)), np.empty((1, 6, 6)), np.empty((6, 6))
    dq, free = np.empty(nv), np.ones(nv)
    zero = (0.0, 0.0, 0.0)
    lt = T.shape[0] - 1
    for b in range(Q0.shape[0]):
        Tb = T[min(b, lt)]
        Rd = (Tb[0, 0], Tb[0, 1], Tb[0, 2], Tb[1, 0], Tb[1, 1], Tb[1, 2], Tb[2, 0], Tb[2, 1], Tb[2, 2])
        pd = (Tb[0, 3], Tb[1, 3], Tb[2, 3])
        q = Q0[b].copy()
        if limits:
            _clamp(tree, lower, upper, q)
        R, p = _jacobian_into(tree, frames, q, f, LOCAL_WORLD_ALIGNED, zero, path, oR, op, J)
        ep, eo = _error(Rd, pd, R, p, e)
        res = np.sqrt(ep * ep + eo * eo) if r == 6 else ep
        mu = damping * damping
        status, it = MAX_ITER, 0
        while True:
            if res < tol:
                status = CONVERGED
                break
            if it >= max_iter:
                break
            if mu > MAX_MU:
                status = STALLED
                break
            it += 1
            free[:] = 1.0
            solved = True
            for _ in range(nv + 1):  # with limits: re-solve without the joints a step would push out of them
                solved = _dls_step(J, free, e, r, mu, A, Ainv, scratch, y, dq)
                if not (solved and limits and _freeze_blocked(tree, lower, upper, q, dq, free)):
                    break
            if not solved:
                mu = max(10.0 * mu, 1e-12)
                continue
            qt = _integrate_q(tree, q, dq, 1.0)
            if limits:
                _clamp(tree, lower, upper, qt)
            R, p = _jacobian_into(tree, frames, qt, f, LOCAL_WORLD_ALIGNED, zero, path, oR, op, Jt)
            tp, to = _error(Rd, pd, R, p, et)
            rt = np.sqrt(tp * tp + to * to) if r == 6 else tp
            if rt < res:  # accept
                if res - rt <= 1e-12 * res:  # no real progress: the closest pose this start leads to
                    status = STALLED
                    q, res, ep, eo = qt, rt, tp, to
                    break
                q, res, ep, eo = qt, rt, tp, to
                J, Jt = Jt, J
                e, et = et, e
                mu = max(0.1 * mu, damping * damping)
            else:
                mu = max(10.0 * mu, 1e-12)
        nq = q.shape[0]
        out[b, :nq] = q
        out[b, nq], out[b, nq + 1], out[b, nq + 2], out[b, nq + 3], out[b, nq + 4] = status, it, res, ep, eo
    keep_alive(model_tree)
    keep_alive(model_frames)


# -- public entry point ----------------------------------------------------------------------------
_ik_batch = _ik_batch


def inverse_kinematics(model, frame, target, q0, *, position_only=False, tol=1e-10, max_iter=100, damping=1e-6,
                       respect_limits=False):
    """A configuration q placing ``frame`` at ``target``, by damped least squares from ``q0`` (module docstring).

    target: a (4, 4) world pose (or (B, 4, 4)); with ``position_only=True`` a (3,) position is enough and the
    orientation is free.  q0: (nq,) or (B, nq).  tol: on |e| (m and rad; position only: m).  damping: the
    smallest damping lambda (mu >= lambda^2).  respect_limits: keep 1-dof joints within their URDF limits.

    Returns (q, report): q of q0's shape (the best configuration found, also when not converged) and a dict
    with ``converged``, ``status`` ("converged", "max_iter" or "stalled": no step reduces the error, e.g. an
    unreachable target), ``iterations``, ``residual`` (|e|), ``position_error`` (m), ``orientation_error``
    (rad, also reported with position_only), each a scalar, or an array of B for a batch.
    """
    checks.check_model(model)
    f = checks.frame(model, frame)
    T, t_batched = checks.poses("target", target, bool(position_only))
    tol = checks.real_number("tol", tol, lo=0.0, lo_open=True)
    damping = checks.real_number("damping", damping, lo=0.0)
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 0:
        raise InputError(f"max_iter: expected an integer >= 0, got {max_iter!r}")
    Q0, q_batched = checks.configurations(model, q0, "q0")
    (Q0, T), B = checks.broadcast([("q0", Q0), ("target", T.reshape(-1, 16))])
    T = T.reshape(B, 4, 4)
    out = np.empty((B, model.nq + 5))  # q, then the report's numbers
    run_chunks(_ik_batch, model.tree, (Q0, T), (model.frame_arrays, f, 3 if position_only else 6, tol,
                                                int(max_iter), damping, bool(respect_limits), model.lower,
                                                model.upper), out)
    rep = out[:, model.nq:]
    out = np.ascontiguousarray(out[:, :model.nq])
    report = {
        "converged": rep[:, 0] == CONVERGED,
        "status": np.array(STATUS)[rep[:, 0].astype(int)],
        "iterations": rep[:, 1].astype(int),
        "residual": rep[:, 2],
        "position_error": rep[:, 3],
        "orientation_error": rep[:, 4],
    }
    if q_batched or t_batched:
        return out, report
    return out[0], {k: v[0].item() for k, v in report.items()}
