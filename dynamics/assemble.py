"""Assembly: a configuration that closes every loop, phi(q) = 0, near a guess (Gauss-Newton on phi).

    q_{k+1} = q_k (+) dq,    dq = -J^+ phi(q_k)   over the free coordinates (J = Phi_q, (+) = integrate)

J^+ is the minimum-norm least-squares inverse (redundant rows and a mechanism's free motion are normal:
the step moves q as little as possible), with backtracking when a full step does not reduce |phi|.  Joints
named in ``fixed`` keep their value (their columns of J are left out): the crank angle of a four-bar, the
actuated joints of a leg.  When the iteration stalls at |phi| > tol the loop cannot close (link lengths that
never meet, fixed values out of reach): an :class:`~dynamics.InputError` with the residual left.
"""

import numpy as np

from . import checks
from .constraints import arrays, close_loops
from .errors import InputError
from .parallel import check_deadline

def _fixed_mask(model, q, fixed):
    """(q with fixed values set, (nv,) 1.0 at free coordinates)."""
    free = np.ones(model.nv)
    if fixed is None:
        return q, free
    items = fixed.items() if isinstance(fixed, dict) else ((name, None) for name in fixed)
    for name, value in items:
        if not isinstance(name, str):
            raise InputError(f"fixed: expected joint names, or a mapping joint name -> value, got {name!r}")
        free[model.v_slice(name)] = 0.0
        if value is not None:
            sl = model.q_slice(name)
            q[sl] = checks.vector(f"fixed[{name!r}]", np.atleast_1d(value), sl.stop - sl.start)
    return q, free


def assemble(model, q_guess, *, fixed=None, tol=1e-12, max_iter=100):
    """A configuration q (nq,) (or (B, nq) for a batch of guesses) with every constraint satisfied,
    max |phi(q)| <= tol, reached from ``q_guess`` by Gauss-Newton with minimum-norm steps.

    ``fixed``: joint names kept at their value in q_guess, or a mapping joint name -> value.  Raises
    InputError when a loop cannot close from the guess (the residual left and the state are named).
    Batches are solved one guess after another (assembly is not a per-step operation), checking the deadline
    of :func:`dynamics.parallel.deadline` between guesses.
    """
    checks.check_model(model)
    Q, batched = checks.configurations(model, q_guess, "q_guess")
    tol = checks.real_number("tol", tol, lo=0.0, lo_open=True)
    C, m = arrays(model)
    out = np.array(Q)
    for b in range(Q.shape[0]):
        check_deadline(b, Q.shape[0])  # (inside dynamics.parallel.deadline, as the service runs it)
        q, free = _fixed_mask(model, out[b].copy(), fixed)
        q, err = close_loops(model, C, m, q, free, tol, int(max_iter)) if m else (q, 0.0)
        if err > tol:
            where = f" (guess {b})" if batched else ""
            raise InputError(f"assemble{where}: the loops cannot close from this guess: max |phi| = {err:.3g} "
                             f"> tol = {tol:g} where Gauss-Newton stalled (links that cannot meet, fixed joints "
                             f"out of reach, or a guess too far away)")
        out[b] = q
    return out if batched else out[0]
