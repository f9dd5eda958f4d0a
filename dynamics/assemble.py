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
from .configuration import integrate_q
from .constraints import arrays, jacobian_batch, residual_batch
from .errors import InputError

_ZERO_V = np.zeros((1, 0))


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


def _assemble_one(model, C, m, q, free, tol, max_iter):
    tree = model.tree
    V = np.zeros((1, model.nv))
    phi, J = np.empty((1, m)), np.empty((1, m, model.nv))

    def residual(x):
        residual_batch(tree, x[None], V, C, phi)
        return phi[0].copy()

    r = residual(q)
    err = np.abs(r).max()
    for _ in range(max_iter):
        if err <= tol:
            return q, err
        jacobian_batch(tree, q[None], V, C, J)
        dq = -np.linalg.lstsq(J[0] * free, r, rcond=1e-12)[0] * free
        step = 1.0
        while step > 1e-6:
            q_new = integrate_q(tree, q, dq, step)
            r_new = residual(q_new)
            if np.abs(r_new).max() < err:
                break
            step *= 0.5
        else:
            break  # no step reduces |phi|: a least-squares minimum with phi != 0
        q, r, err = q_new, r_new, np.abs(r_new).max()
    return q, err


def assemble(model, q_guess, *, fixed=None, tol=1e-12, max_iter=100):
    """A configuration q (nq,) (or (B, nq) for a batch of guesses) with every constraint satisfied,
    max |phi(q)| <= tol, reached from ``q_guess`` by Gauss-Newton with minimum-norm steps.

    ``fixed``: joint names kept at their value in q_guess, or a mapping joint name -> value.  Raises
    InputError when a loop cannot close from the guess (the residual left and the state are named).
    Batches are solved one guess after another (assembly is not a per-step operation).
    """
    checks.check_model(model)
    Q, batched = checks.configurations(model, q_guess, "q_guess")
    tol = checks.real_number("tol", tol, lo=0.0, lo_open=True)
    C, m = arrays(model)
    out = np.array(Q)
    for b in range(Q.shape[0]):
        q, free = _fixed_mask(model, out[b].copy(), fixed)
        q, err = _assemble_one(model, C, m, q, free, tol, int(max_iter)) if m else (q, 0.0)
        if err > tol:
            where = f" (guess {b})" if batched else ""
            raise InputError(f"assemble{where}: the loops cannot close from this guess: max |phi| = {err:.3g} "
                             f"> tol = {tol:g} where Gauss-Newton stalled (links that cannot meet, fixed joints "
                             f"out of reach, or a guess too far away)")
        out[b] = q
    return out if batched else out[0]
