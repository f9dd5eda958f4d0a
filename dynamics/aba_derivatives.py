"""Analytical derivatives of forward dynamics (Carpentier and Mansard, RSS 2018; Pinocchio's
``computeABADerivatives``).

    a = ABA(q, v, tau) = M(q)^-1 (tau - C(q, v) v - g(q) + J^T f_ext)

Differentiating M(q) a + b(q, v) = tau at a fixed tau (the identity RNEA(q, v, ABA(q, v, tau)) = tau):

    da/dq = -M^-1 dtau/dq (q, v, a),    da/dv = -M^-1 dtau/dv (q, v, a),    da/dtau = M^-1

with dtau/dq, dtau/dv the RNEA derivatives (:mod:`dynamics.rnea_derivatives`) evaluated at the ABA's
acceleration, and M^-1 computed directly (:mod:`dynamics.minverse`).  q derivatives are in the tangent space
(nv columns, along q (+) dq with dq in each joint's frame), as Pinocchio's.

For other compiled code (an implicit integrator's Jacobian, simulation sensitivities) the kernel
:func:`_aba_derivatives_into` takes a workspace from :func:`_derivatives_workspace` (owned arrays, one per
thread) and leaves the acceleration in ``ws.a``.
"""

from typing import NamedTuple

import numpy as np

from . import aba, checks, minverse, rnea_derivatives
from ._numba import (MATRIX, SingleCall, VECTOR, address, borrowed, inline_kernel, keep_alive, kernel, scratch,
                     view)
from .checks import DONE, GENERAL, NOT_ARRAYS, _config_shape_ok, _finite
from .data import _take
from .errors import InputError
from .model import _unpack
from .minverse import Checked, run_checked


class Work(NamedTuple):
    """The scratch of one state: ABA's (:class:`dynamics.aba.Work`), the RNEA derivatives'
    (:class:`dynamics.rnea_derivatives.Work`), M^-1's (:mod:`dynamics.minverse`), dtau/dq and dtau/dv
    (nv, nv) each, M (nv, nv) and the acceleration a (nv,)."""

    fd: object
    rd: object
    mi: object
    dq: object
    dv: object
    M: object
    a: object


@inline_kernel
def _work_at(base, o, nb, nv):
    """A :class:`Work` carved from the buffer at ``base`` from offset o, and the offset after it."""
    fd, o = aba._work_at(base, o, nb, nv)
    rd, o = rnea_derivatives._work_at(base, o, nb, nv)
    mi, o = minverse._work_at(base, o, nb, nv)
    dq, o = _take(base, o, (nv, nv))
    dv, o = _take(base, o, (nv, nv))
    M, o = _take(base, o, (nv, nv))
    a, o = _take(base, o, nv)
    return Work(fd, rd, mi, dq, dv, M, a), o


@inline_kernel
def _derivatives_workspace(nb, nv):
    """(buffer, work): a :class:`Work` for nb bodies and nv coordinates carved from one owned buffer.  Keep the
    buffer referenced as long as the work is used (in compiled code: hold both, end with ``keep_alive(buffer)``);
    one per thread.  Compiled code only, inlined: as a kernel of its own it compiled a Python wrapper boxing the
    whole work (~2.4 s of a first contact simulation from an empty cache)."""
    buf = np.empty(_work_at(0, 0, nb, nv)[1])
    return buf, _work_at(address(buf), 0, nb, nv)[0]


#: above this nv the products go to BLAS (np.dot): its dgemm is ~6x faster than the compiled loops at nv = 50
#: (they are not vectorised over the workspace's views), but each call takes a lock in OpenBLAS's buffer pool,
#: which threads of a batch contend for: at small nv that lock cost more than the products themselves
BLAS_NV = 24


@inline_kernel
def _neg_products(Minv, dq, dv, out_q, out_v):
    """out_q = -Minv dq and out_v = -Minv dv (nv, nv)."""
    n = Minv.shape[0]
    if n > BLAS_NV:
        np.dot(Minv, dq, out_q)
        np.dot(Minv, dv, out_v)
        for i in range(n):
            for j in range(n):
                out_q[i, j] = -out_q[i, j]
                out_v[i, j] = -out_v[i, j]
        return
    for i in range(n):
        for j in range(n):
            x = y = 0.0
            for k in range(n):
                m = Minv[i, k]
                x -= m * dq[k, j]
                y -= m * dv[k, j]
            out_q[i, j] = x
            out_v[i, j] = y


@inline_kernel
def _aba_derivatives_terms(tree, q, v, tau, gravity, f_ext, ws, da_dq, da_dv, Minv):
    """One state: a into ws.a, then (da/dq, da/dv, M^-1).  Returns -1, or a body whose joint makes M singular
    (then nothing is valid)."""
    # ABA and M^-1 are calls of their own kernels; the RNEA derivatives are inlined (called, their loops read
    # the workspace views' shapes from memory and ran ~6x slower; all three inlined, ~4x)
    singular = aba._aba_into(tree, q, v, tau, gravity, f_ext, ws.fd, ws.a)
    if singular >= 0:
        return singular
    singular = minverse._minverse_into(tree, q, ws.mi, Minv)
    if singular >= 0:
        return singular
    rnea_derivatives._rnea_derivatives_terms(tree, q, v, ws.a, gravity, f_ext, ws.rd, ws.dq, ws.dv, ws.M)
    _neg_products(Minv, ws.dq, ws.dv, da_dq, da_dv)
    return -1


@kernel
def _aba_derivatives_into(tree, q, v, tau, gravity, f_ext, ws, da_dq, da_dv, Minv):
    """Forward dynamics derivatives of one state into da_dq, da_dv, Minv (nv, nv); the acceleration into ws.a.
    ``ws`` from :func:`_derivatives_workspace`; f_ext (nb, 6) [force, torque] per body in its frame, or
    (0, 6).  Returns -1, or a body whose joint makes M singular.  Callable from other kernels."""
    return _aba_derivatives_terms(tree, q, v, tau, gravity, f_ext, ws, da_dq, da_dv, Minv)


@kernel
def _aba_derivatives_batch(tree, Q, V, T, F, gravity, out, status):
    """out[b] = (da/dq, da/dv, M^-1) at the rows of Q, V, T (V, T, F may have one row); status[b] = -1 or a
    singular body."""
    tree, Q, V, T, F, out = borrowed(tree), borrowed(Q), borrowed(V), borrowed(T), borrowed(F), borrowed(out)
    status = borrowed(status)
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    buf = np.empty(_work_at(0, 0, nb, nv)[1])
    ws = _work_at(address(buf), 0, nb, nv)[0]
    lf, lv, lt = F.shape[0] - 1, V.shape[0] - 1, T.shape[0] - 1
    for b in range(Q.shape[0]):
        status[b] = _aba_derivatives_terms(tree, Q[b], V[min(b, lv)], T[min(b, lt)], gravity, F[min(b, lf)], ws,
                                           out[b, 0], out[b, 1], out[b, 2])
    keep_alive(buf)


def _aba_derivatives_one(packed, q, v, tau, da_dq, da_dv, Minv):
    """One state from Python, inputs checked in the call (a singular joint takes the general path, which names
    it)."""
    tree, gravity, nq = _unpack(packed)
    nb, nv = tree.parents.shape[0], tree.S.shape[0]
    if not (_config_shape_ok(tree, nq, q) and v.shape[0] == nv and tau.shape[0] == nv):
        return GENERAL
    buf = scratch(_work_at(0, 0, nb, nv)[1])
    singular = _aba_derivatives_terms(tree, q, v, tau, gravity, view(buf, 0, (0, 6)),
                                      _work_at(address(buf), 0, nb, nv)[0], da_dq, da_dv, Minv)
    keep_alive(buf)
    return DONE if singular < 0 and _finite(da_dq) and _finite(da_dv) else GENERAL


_aba_derivatives_single = SingleCall(_aba_derivatives_one, VECTOR, VECTOR, VECTOR, MATRIX, MATRIX, MATRIX)
_aba_derivatives_checked = Checked(_aba_derivatives_batch)


def forward_dynamics_derivatives(model, q, v, tau, *, gravity=None, f_ext=None):
    """(da_dq, da_dv, Minv): the partial derivatives of a = forward_dynamics(model, q, v, tau) (analytical,
    module docstring); da/dtau = Minv = M(q)^-1.

    da_dq is taken in the tangent space (nv columns, as :func:`inverse_dynamics_derivatives`).  Inputs as
    :func:`dynamics.forward_dynamics` on a model without constraints; each result is (nv, nv), or (B, nv, nv)
    for a batch.  Raises InputError naming the joint when M is singular, and on a model with constraints
    (whose accelerations are not the ABA's).
    """
    if getattr(model, "constraints", None):
        raise InputError("model: forward_dynamics_derivatives differentiates the unconstrained dynamics; this "
                         "model has constraints (differentiate the model without them, or its constrained "
                         "dynamics with constrained_forward_dynamics_derivatives)")
    try:  # one state: one compiled call, which checks q, v and tau itself (anything else takes the general path)
        if gravity is None and f_ext is None:
            nv = model.nv
            dq, dv, Minv = np.empty((nv, nv)), np.empty((nv, nv)), np.empty((nv, nv))
            if _aba_derivatives_single.call(model.packed, q, v, tau, dq, dv, Minv) == DONE:
                return dq, dv, Minv
    except NOT_ARRAYS:  # not a model, or arrays of other types: the general path says what is wrong or converts
        pass
    checks.check_model(model)
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    out = np.empty((B, 3, model.nv, model.nv))
    run_checked(model, _aba_derivatives_checked, (Q, V, T, F), (g,), out, "forward dynamics derivatives")
    if batched:
        return out[:, 0], out[:, 1], out[:, 2]
    return out[0, 0], out[0, 1], out[0, 2]
