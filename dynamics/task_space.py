"""Task-space (operational-space) inertia (Khatib 1987; Featherstone 2008, sec. 9.3).

For a frame's Jacobian J (chosen rows, chosen reference, :mod:`dynamics.jacobians`), the task-space equation of
motion F = Lambda xdd + mu + p has the inertia

    Lambda = (J M^-1 J^T)^-1,

the inertia the end effector presents to a force applied at it.  J M^-1 J^T is formed by the core in one pass
per state (``core/task_space.cpp``: M^-1 by :mod:`dynamics.minverse`, over the frame's support columns only); its inverse is taken by a
symmetric eigendecomposition, which also gives the condition number: near a singularity of J (an arm
stretched out) J M^-1 J^T loses rank and Lambda blows up.  Without damping a condition number above
:data:`MAX_CONDITION` is an error naming the frame; with ``damping`` = d > 0, Lambda = (J M^-1 J^T + d 1)^-1
(damped, always finite).
"""

import numpy as np

from . import _core, checks
from .errors import InputError
from .parallel import run

#: J M^-1 J^T with a larger condition number is singular (half of double precision's digits are gone)
MAX_CONDITION = 1e8


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
    JMJ = run(_core.jminvjt_batch, model, Q, f, ref, rows, out=np.empty((Q.shape[0], rows.size, rows.size)),
              singular="operational space inertia")
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
