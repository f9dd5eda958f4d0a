"""Analytical derivatives of forward dynamics (Carpentier and Mansard, RSS 2018; Pinocchio's
``computeABADerivatives``).

    a = ABA(q, v, tau) = M(q)^-1 (tau - C(q, v) v - g(q) + J^T f_ext)

Differentiating M(q) a + b(q, v) = tau at a fixed tau (the identity RNEA(q, v, ABA(q, v, tau)) = tau):

    da/dq = -M^-1 dtau/dq (q, v, a),    da/dv = -M^-1 dtau/dv (q, v, a),    da/dtau = M^-1

with dtau/dq, dtau/dv the RNEA derivatives (:mod:`dynamics.rnea_derivatives`) evaluated at the ABA's
acceleration.  q derivatives are in the tangent space (nv columns, along q (+) dq with dq in each joint's
frame), as Pinocchio's.

The public function is the core's (``core/aba_derivatives.cpp``): the ABA, M^-1 and the RNEA derivatives at
the ABA's acceleration, then the two products; this module checks the arguments and calls it.

The numba kernel below stays for the compiled callers that link it (the simulation's Radau Jacobian, the torque
sources' and the closed loop's derivatives) until they move to the core.  It takes four passes over the tree, all
in the world frame, sharing what each computes:

1. forward: the RNEA derivatives' velocity part (world poses, axes J, ov, dV, dAv, world inertias, dY) and
   the ABA's bias forces pA_i = ov_i x* I_i ov_i - f_ext_i and velocity products c_i = ov_i x (J_i qd_i);
2. backward: the articulated inertias and M^-1's rows (:mod:`dynamics.minverse`), with the ABA's
   u_i = tau_i - J_i^T pA_i and pA_p += pA_i + I^A_i c_i + U_i D_i^-1 (u_i - U_i^T c_i);
3. forward: M^-1's columns, the acceleration qdd_i = D_i^-1 u_i - (U_i D_i^-1)^T (oa_p + c_i) (oa_0 = -g),
   oa_i and the RNEA derivatives' acceleration part at it;
4. backward: the RNEA derivatives' composites and their blocks;

then the products -M^-1 dtau/dq, -M^-1 dtau/dv.  Every compiled caller calls the one kernel
:func:`_aba_derivatives_into` with the address of a workspace buffer of :func:`_work_size` floats (one per
thread).
"""

from typing import NamedTuple

import numpy as np

from . import _core, checks, minverse, rnea_derivatives
from ._numba import helper, inline_kernel, kernel
from .data import _take, _take_int
from .errors import InputError
from .parallel import run
from .spatial import _store_inertia6, add, dot6, get6, load3, load33, scale, set6


class Work(NamedTuple):
    """The scratch of one state: the RNEA derivatives' (:class:`dynamics.rnea_derivatives.Work`, whose forward
    pass also gives the ABA's world poses, axes J, velocities and inertias), the articulated-body passes' (I^A
    (nb, 6, 6), U and U D^-1 (nv, 6), D^-1 (nb, 6, 6), M^-1's column forces F (nb, nv, 6), subtree sizes,
    two 6x6 scratch matrices), the ABA's bias forces pA and velocity products c (nb, 6) and u (nv,);
    dtau/dq, dtau/dv and M (nv, nv) each, and the acceleration a (nv,)."""

    rd: object
    IA: object
    U: object
    UD: object
    Dinv: object
    F: object
    nsub: object
    D: object
    scratch: object
    pA: object
    c: object
    u: object
    dq: object
    dv: object
    M: object
    a: object


@inline_kernel
def _work_at(base, o, nb, nv):
    """A :class:`Work` carved from the buffer at ``base`` from offset o, and the offset after it."""
    rd, o = rnea_derivatives._work_at(base, o, nb, nv)
    IA, o = _take(base, o, (nb, 6, 6))
    U, o = _take(base, o, (nv, 6))
    UD, o = _take(base, o, (nv, 6))
    Dinv, o = _take(base, o, (nb, 6, 6))
    F, o = _take(base, o, (nb, nv, 6))
    nsub, o = _take_int(base, o, nb)
    D, o = _take(base, o, (6, 6))
    scr, o = _take(base, o, (6, 6))
    pA, o = _take(base, o, (nb, 6))
    c, o = _take(base, o, (nb, 6))
    u, o = _take(base, o, nv)
    dq, o = _take(base, o, (nv, nv))
    dv, o = _take(base, o, (nv, nv))
    M, o = _take(base, o, (nv, nv))
    a, o = _take(base, o, nv)
    return Work(rd, IA, U, UD, Dinv, F, nsub, D, scr, pA, c, u, dq, dv, M, a), o


@inline_kernel
def _work_size(nb, nv):
    """The floats of one state's workspace (:class:`Work`) for nb bodies and nv coordinates."""
    return _work_at(0, 0, nb, nv)[1]


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


@kernel
def _aba_derivatives_into(tree, q, v, tau, gravity, f_ext, base, da_dq, da_dv, Minv):
    """Forward dynamics derivatives of one state into da_dq, da_dv, Minv (nv, nv), in four passes over the tree
    (module docstring); the acceleration into the workspace's ``a``.  ``base``: the address of a workspace
    buffer of :func:`_work_size` floats, which the caller keeps alive; f_ext (nb, 6) [force, torque] per body in
    its frame, or (0, 6).  Returns -1, or a body whose joint makes M singular (then nothing is valid).

    One kernel, compiled (and cached) once for every caller, which passes the buffer's address: the workspace's
    views are carved here, so their inner strides are constants of this function's code.  (Passed in as a
    :class:`Work` argument, one Panda call from Python took 7.8-8.8 us against 5.0-5.3 us with the views made
    in the function.
    Inlined into each caller instead, as before, its ~300 blocks cost numba's inliner ~22 s per caller: it
    deep-copies the callee's variable scope once per block.)"""
    parents, v_idx, nv_j = tree.parents, tree.v_idx, tree.nv_j
    nb, nv = parents.shape[0], tree.S.shape[0]
    # the workspace is unpacked once, as a tuple: numba's dead-code elimination keeps a write to an array it
    # knows aliases a live variable, and it follows tuple items but not attributes of a tuple that was not an
    # argument (bare item writes to ``ws.X`` were dropped)
    rd, IA, U, UD, Dinv, F, nsub, D, scr, pA, c, u, dq, dv, M, a = _work_at(base, 0, nb, nv)[0]
    for r in range(nv):
        for k in range(nv):
            dq[r, k] = 0.0
            dv[r, k] = 0.0
            M[r, k] = 0.0
    for i in range(nb):  # 1: kinematics, velocities, world inertias, bias forces
        cw, cv = rnea_derivatives._velocity_step(tree, i, q, v, f_ext, rd)
        set6(c, i, cw, cv)
        pn, pf = get6(rd.F, i)
        set6(pA, i, pn, pf)
        _store_inertia6(IA, i, rd.mass[i], load3(rd.h, i), load33(rd.Io, i))
        _set_item(nsub, i, nv_j[i])
    for i in range(nb - 1, -1, -1):
        if parents[i] >= 0:
            _set_item(nsub, parents[i], nsub[parents[i]] + nsub[i])
    for i in range(nb - 1, -1, -1):  # 2: articulated inertias, M^-1's backward pass, the ABA's bias forces
        k0, nj, ns, par = v_idx[i], nv_j[i], nsub[i], parents[i]
        if not minverse._backward_body(IA, rd.J, U, UD, Dinv, F, Minv, D, scr, i, k0, nj, ns, par):
            return i
        _bias_backward(IA, rd.J, U, UD, pA, c, u, tau, i, k0, nj, par)
    for i in range(nb):  # 3: M^-1's forward pass, the acceleration, oa and the RNEA's forces at it
        k0, nj, ns, par = v_idx[i], nv_j[i], nsub[i], parents[i]
        minverse._forward_body(rd.J, UD, F, Minv, i, k0, nj, ns, par, nv)
        _acceleration(UD, Dinv, c, u, rd.oa, gravity, a, i, k0, nj, par)
        cw, cv = get6(c, i)
        rnea_derivatives._acceleration_step(tree, i, a, gravity, rd, cw, cv)
    for i in range(nb - 1, -1, -1):  # 4: the RNEA derivatives' backward pass
        rnea_derivatives._backward_step(tree, i, rd, rd.tau, dq, dv, M)
    for r in range(nv):
        for k in range(r + 1, nv):
            Minv[k, r] = Minv[r, k]
    _neg_products(Minv, dq, dv, da_dq, da_dv)
    return -1


@helper
def _set_item(A, i, x):
    """A[i] = x.  Items of the workspace's 1-d views are set through a helper (as
    :func:`dynamics.rnea_derivatives._set_item`): a bare assignment was dropped as dead when these passes were
    inlined into the batch kernel, next to the borrowed tree; the views are still made inside the kernel that
    writes them, which is the case numba's dead-code elimination does not follow."""
    A[i] = x


@inline_kernel
def _bias_backward(IA, J, U, UD, pA, c, u, tau, i, k0, nj, par):
    """The ABA's backward step at body i in the world frame: u_i = tau_i - J_i^T pA_i, then
    pA_p += pA_i + I^A_i c_i + U_i D_i^-1 (u_i - U_i^T c_i)."""
    pn, pf = get6(pA, i)
    for k in range(k0, k0 + nj):
        Jw, Jv = get6(J, k)
        _set_item(u, k, tau[k] - dot6(Jw, Jv, pn, pf))
    if par < 0:
        return
    cw, cv = get6(c, i)
    for k in range(k0, k0 + nj):  # pA_i += U_i D_i^-1 (u_i - U_i^T c_i), column by column
        Uw, Uv = get6(U, k)
        Dw, Dv = get6(UD, k)
        y = u[k] - dot6(Uw, Uv, cw, cv)
        pn, pf = add(pn, scale(y, Dw)), add(pf, scale(y, Dv))
    IAc = _times6(IA, i, cw, cv)
    qn, qf = get6(pA, par)
    set6(pA, par, add(qn, add(pn, IAc[0])), add(qf, add(pf, IAc[1])))


@helper
def _times6(I, i, w, v):
    """I[i] (w, v) for a 6x6 matrix I[i], as two 3-tuples."""
    x0, x1, x2, x3, x4, x5 = w[0], w[1], w[2], v[0], v[1], v[2]
    y0 = I[i, 0, 0] * x0 + I[i, 0, 1] * x1 + I[i, 0, 2] * x2 + I[i, 0, 3] * x3 + I[i, 0, 4] * x4 + I[i, 0, 5] * x5
    y1 = I[i, 1, 0] * x0 + I[i, 1, 1] * x1 + I[i, 1, 2] * x2 + I[i, 1, 3] * x3 + I[i, 1, 4] * x4 + I[i, 1, 5] * x5
    y2 = I[i, 2, 0] * x0 + I[i, 2, 1] * x1 + I[i, 2, 2] * x2 + I[i, 2, 3] * x3 + I[i, 2, 4] * x4 + I[i, 2, 5] * x5
    y3 = I[i, 3, 0] * x0 + I[i, 3, 1] * x1 + I[i, 3, 2] * x2 + I[i, 3, 3] * x3 + I[i, 3, 4] * x4 + I[i, 3, 5] * x5
    y4 = I[i, 4, 0] * x0 + I[i, 4, 1] * x1 + I[i, 4, 2] * x2 + I[i, 4, 3] * x3 + I[i, 4, 4] * x4 + I[i, 4, 5] * x5
    y5 = I[i, 5, 0] * x0 + I[i, 5, 1] * x1 + I[i, 5, 2] * x2 + I[i, 5, 3] * x3 + I[i, 5, 4] * x4 + I[i, 5, 5] * x5
    return (y0, y1, y2), (y3, y4, y5)


@inline_kernel
def _acceleration(UD, Dinv, c, u, oa, gravity, a, i, k0, nj, par):
    """The ABA's forward step at body i in the world frame: qdd_i = D_i^-1 u_i - (U_i D_i^-1)^T (oa_p + c_i),
    into a (oa_0 = -g)."""
    if par < 0:
        x0, x1, x2, x3, x4, x5 = 0.0, 0.0, 0.0, -gravity[0], -gravity[1], -gravity[2]
    else:
        x0, x1, x2, x3, x4, x5 = oa[par, 0], oa[par, 1], oa[par, 2], oa[par, 3], oa[par, 4], oa[par, 5]
    x0, x1, x2, x3, x4, x5 = x0 + c[i, 0], x1 + c[i, 1], x2 + c[i, 2], x3 + c[i, 3], x4 + c[i, 4], x5 + c[i, 5]
    for j in range(nj):
        y = 0.0
        for b in range(nj):
            y += Dinv[i, j, b] * u[k0 + b]
        k = k0 + j
        _set_item(a, k, y - (UD[k, 0] * x0 + UD[k, 1] * x1 + UD[k, 2] * x2 + UD[k, 3] * x3 + UD[k, 4] * x4
                             + UD[k, 5] * x5))


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
    if gravity is None and f_ext is None:  # one state: one core call, which checks q, v and tau itself
        try:
            out = _core.aba_derivatives(model.core, q, v, tau)
            if out is not None:
                return out
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    checks.check_model(model)
    Q, (V, T), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("tau", tau, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    out = run(_core.aba_derivatives_batch, model, Q, V, T, F, g, out=np.empty((B, 3, model.nv, model.nv)),
              singular="forward dynamics derivatives")
    if batched:
        return out[:, 0], out[:, 1], out[:, 2]
    return out[0, 0], out[0, 1], out[0, 2]
