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

The iteration is the core's (``core/inverse_kinematics.cpp``); this module checks the arguments and calls it.
"""

import numpy as np

from . import _core, checks
from .errors import InputError
from .parallel import run

CONVERGED, MAX_ITER, STALLED = 0, 1, 2
STATUS = ("converged", "max_iter", "stalled")


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
    out = run(_core.inverse_kinematics_batch, model, Q0, T, f, 3 if position_only else 6, tol, min(int(max_iter), 2**31 - 1),
              damping, bool(respect_limits), out=np.empty((B, model.nq + 5)))  # q, then the report's numbers
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
