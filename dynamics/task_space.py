"""Task-space (operational-space) inertia (Khatib 1987; Featherstone 2008, sec. 9.3).

For a frame's Jacobian J (chosen rows, chosen reference, :mod:`dynamics.jacobians`), the task-space equation of
motion F = Lambda xdd + mu + p has the inertia

    Lambda = (J M^-1 J^T)^-1,

the inertia the end effector presents to a force applied at it.  J M^-1 J^T is formed in one compiled pass per
state (M^-1 by :mod:`dynamics.minverse`, over the frame's support columns only); its inverse is taken by a
symmetric eigendecomposition, which also gives the condition number: near a singularity of J (an arm
stretched out) J M^-1 J^T loses rank and Lambda blows up.  Without damping a condition number above
:data:`MAX_CONDITION` is an error naming the frame; with ``damping`` = d > 0, Lambda = (J M^-1 J^T + d 1)^-1
(damped, always finite).
"""

import numpy as np

from . import checks
from ._numba import borrow, keep_alive, kernel
from .errors import InputError
from .jacobians import _jacobian_into
from .kinematics import _support
from .minverse import Checked, _minverse_into, run_checked, _workspace

#: J M^-1 J^T with a larger condition number is singular (half of double precision's digits are gone)
MAX_CONDITION = 1e8


@kernel
def _jmj_batch(model_tree, Q, model_frames, f, ref, rows, out, status):
    """out[b] = J[rows] M^-1 J[rows]^T at Q[b]; status[b] = -1 or a body whose joint makes M singular."""
    # borrowed: the kernels below take the arrays out of the tuples per body and per state: no reference counts
    tree, frames = borrow(model_tree), borrow(model_frames)
    nb, nv, r = tree.parents.shape[0], tree.S.shape[0], rows.shape[0]
    path, oR, op = np.empty(nb, np.int64), np.empty((nb, 3, 3)), np.empty((nb, 3))
    ws = _workspace(nb, nv)
    J, Minv, JM = np.zeros((6, nv)), np.empty((nv, nv)), np.empty((r, nv))
    cols = np.empty(nv, np.int64)  # the support's columns: J is zero elsewhere
    n = 0
    for t in range(_support(tree.parents, frames.body[f], path)):
        for k in range(tree.v_idx[path[t]], tree.v_idx[path[t]] + tree.nv_j[path[t]]):
            cols[n] = k
            n += 1
    for b in range(Q.shape[0]):
        _jacobian_into(tree, frames, Q[b], f, ref, (0.0, 0.0, 0.0), path, oR, op, J)
        status[b] = _minverse_into(tree, Q[b], ws, Minv)
        for a in range(r):
            for c in range(n):
                x = 0.0
                for t in range(n):
                    x += J[rows[a], cols[t]] * Minv[cols[t], cols[c]]
                JM[a, c] = x
        for a in range(r):
            for e in range(r):
                x = 0.0
                for t in range(n):
                    x += JM[a, t] * J[rows[e], cols[t]]
                out[b, a, e] = x
    keep_alive(model_tree)
    keep_alive(model_frames)


# -- public entry point ----------------------------------------------------------------------------
_jmj_batch = Checked(_jmj_batch)


def operational_space_inertia(model, q, frame, *, reference="local_world_aligned", rows=None, damping=0.0):
    """Lambda = (J M^-1 J^T)^-1 for the frame's Jacobian J in ``reference`` (:func:`dynamics.frame_jacobian`),
    restricted to ``rows`` of [linear; angular] (None: all 6; e.g. ``slice(0, 3)`` for the position only).

    Returns (r, r), or (B, r, r) for a batch.  Near a singularity (condition number of J M^-1 J^T above
    MAX_CONDITION) without damping: an InputError naming the frame and the condition number; ``damping`` d > 0
    gives (J M^-1 J^T + d 1)^-1 instead.
    """
    checks.check_model(model)
    f = checks.frame(model, frame)
    ref = checks.reference(reference)
    rows = checks.rows(rows)
    d = checks.real_number("damping", damping, lo=0.0)
    Q, batched = checks.configurations(model, q)
    JMJ = np.empty((Q.shape[0], rows.size, rows.size))
    run_checked(model, _jmj_batch, (Q,), (model.frame_arrays, f, ref, rows), JMJ, "operational space inertia")
    ev, vec = np.linalg.eigh(JMJ)
    if d == 0.0:
        with np.errstate(divide="ignore"):
            cond = np.where(ev[:, 0] > 0.0, ev[:, -1] / ev[:, 0], np.inf)
        bad = np.flatnonzero(~(cond <= MAX_CONDITION))
        if bad.size:
            k = int(bad[0])
            where = f" (state {k})" if batched else ""
            raise InputError(f"frame {model.frame_names[f]!r}: J M^-1 J^T is singular{where}, condition number "
                             f"{cond[k]:.1e} > {MAX_CONDITION:.0e} (a singular configuration of the frame's "
                             f"Jacobian); pass damping > 0 or fewer rows")
    Lam = (vec / (ev + d)[:, None, :]) @ vec.transpose(0, 2, 1)
    return Lam if batched else Lam[0]
