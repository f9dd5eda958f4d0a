"""Inverse dynamics by the Recursive Newton-Euler Algorithm (Featherstone 2008, sec. 5.3, Table 5.1).

    tau = M(q) a + C(q, v) v + g(q) - sum_i J_i^T f_ext_i

Body-frame formulation.  Gravity enters as a fictitious upward acceleration of the world, a_0 = (0, -g).
Forward pass, for each body i with parent p and joint velocity v_J = S_i qd_i:

    v_i = X_i v_p + S_i qd_i
    a_i = X_i a_p + S_i qdd_i + v_i x (S_i qd_i)
    f_i = I_i a_i + v_i x* I_i v_i - f_ext_i

Backward pass:  tau_i = S_i^T f_i ,  f_p += X_i^T f_i .

The algorithm is the core's (``core/rnea.cpp``); this module checks the arguments and calls it.
"""

from typing import NamedTuple

import numpy as np

from . import _core, checks
from ._numba import helper, inline_kernel, kernel
from .data import Data, _data_at, _forward_body, _take
from .joints import _joint_motion, _project_force
from .parallel import run
from .spatial import add, cross_force, force_to_parent, inertia_times, load3, load33, motion_to_child, store3


def _run(model, q, v, a, gravity, f_ext):
    """The general path: any batch, gravity or external forces; every argument checked and converted."""
    checks.check_model(model)
    Q, (V, A), B, batched = checks.state_batch(model, q, (("v", v, model.nv), ("a", a, model.nv)))
    F = checks.external_forces(model, f_ext, B)
    g = checks.gravity_vector(model, gravity)
    with_v, with_a = bool(V.any()), bool(A.any())  # zero terms are skipped, not computed
    out = run(_core.rnea_batch, model, Q, V, A, F, g, with_v, with_a, out=np.empty((B, model.nv)))
    return out if batched else out[0]


def skipped_terms(v=None, a=None, gravity=(0.0, 0.0, -9.81)):
    """Names of the terms a call with these inputs does not compute (for scene reports)."""
    out = []
    if v is None or not np.any(v):
        out.append("velocity products")
    if a is None or not np.any(a):
        out.append("joint accelerations")
    if gravity is not None and not np.any(gravity):
        out.append("gravity")
    return out


def inverse_dynamics(model, q, v, a, *, gravity=None, f_ext=None):
    """Joint torques tau = M(q) a + C(q, v) v + g(q) - J^T f_ext (RNEA).

    q: (nq,) or (B, nq); v, a: (nv,) or (B, nv); gravity: (3,) in the world frame (default model.gravity);
    f_ext: (nbodies, 6) or (B, nbodies, 6), one [force, torque] per body in its body frame, torque about the
    body frame origin.  Returns tau of shape (nv,) or (B, nv).
    """
    if gravity is None and f_ext is None:  # one state: one core call, which checks q, v and a itself
        try:
            tau = _core.rnea(model.core, q, v, a)
            if tau is not None:
                return tau
        except checks.NOT_A_MODEL:  # the general path says what is wrong
            pass
    return _run(model, q, v, a, gravity, f_ext)


def gravity_torques(model, q, *, gravity=None):
    """g(q): the torques that hold the robot still against gravity, (nv,) or (B, nv)."""
    if gravity is None:  # the fast path, as in inverse_dynamics
        try:
            tau = _core.gravity_torques(model.core, q)
            if tau is not None:
                return tau
        except checks.NOT_A_MODEL:
            pass
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    out = run(_core.gravity_batch, model, Q, checks.gravity_vector(model, gravity), out=np.empty((Q.shape[0], model.nv)))
    return out if batched else out[0]


def bias_forces(model, q, v, *, gravity=None):
    """C(q, v) v + g(q): inverse dynamics at zero acceleration, (nv,) or (B, nv)."""
    if gravity is None:  # the fast path, as in inverse_dynamics
        try:
            tau = _core.bias_forces(model.core, q, v)
            if tau is not None:
                return tau
        except checks.NOT_A_MODEL:
            pass
    checks.check_model(model)
    return _run(model, q, v, np.zeros(model.nv), gravity, None)


# -- numba kernels that the constrained dynamics and the torque sources still call (until they move to the core)

class Work(NamedTuple):
    """RNEA's scratch for one state: the forward pass's :class:`~dynamics.data.Data`, then per body (nb, 3)
    its spatial acceleration (aw, av) and the force it transmits to its parent (n, f), body frame."""

    d: Data
    aw: object
    av: object
    n: object
    f: object


@inline_kernel
def _work_at(base, o, nb):
    """A :class:`Work` carved from the buffer at ``base`` from offset o (at base 0: only its size), and the
    offset after it."""
    d, o = _data_at(base, o, nb)
    aw, o = _take(base, o, (nb, 3))
    av, o = _take(base, o, (nb, 3))
    n, o = _take(base, o, (nb, 3))
    f, o = _take(base, o, (nb, 3))
    return Work(d, aw, av, n, f), o


@helper
def _workspace(nb):
    """A :class:`Work` of owned arrays, which the caller may keep (a torque source's scratch)."""
    d = Data(np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)),
             np.empty((nb, 3)))
    return Work(d, np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)))


@inline_kernel
def _rnea_terms(tree, q, v, a, gravity, f_ext, ws, tau, with_v, with_a):
    """RNEA for one state into ``tau``; ``f_ext`` is (nb, 6) [force, torque] per body or (0, 6).

    ``with_v=False`` (v is zero) skips the velocity pass and every velocity-product term; ``with_a=False``
    (a is zero) skips the joint accelerations: the caller promises those inputs are zero.
    """
    parents, mass, hs, Ios = tree.parents, tree.mass, tree.h, tree.Io
    d = ws.d
    zero = (0.0, 0.0, 0.0)
    a0 = (-gravity[0], -gravity[1], -gravity[2])  # the world accelerates up: a_0 = (0, -g)
    nb = parents.shape[0]
    for i in range(nb):  # X_i, v_i, c_i;  a_i = X_i a_p + S_i qdd_i + c_i,  f_i = I a + v x* I v - f_ext
        R, p, w, vl, cw, cv = _forward_body(tree, i, q, v, d, with_v)
        par = parents[i]
        if par < 0:
            aw, al = motion_to_child(R, p, zero, a0)
        else:
            aw, al = motion_to_child(R, p, load3(ws.aw, par), load3(ws.av, par))
        if with_a:
            sw, sv = _joint_motion(tree, i, a)
            aw, al = add(aw, sw), add(al, sv)
        m, h, Io = mass[i], load3(hs, i), load33(Ios, i)
        if with_v:
            aw, al = add(aw, cw), add(al, cv)
        n, f = inertia_times(m, h, Io, aw, al)
        if with_v:
            hn, hf = inertia_times(m, h, Io, w, vl)
            bn, bf = cross_force(w, vl, hn, hf)
            n, f = add(n, bn), add(f, bf)
        if f_ext.shape[0] > 0:
            n = (n[0] - f_ext[i, 3], n[1] - f_ext[i, 4], n[2] - f_ext[i, 5])
            f = (f[0] - f_ext[i, 0], f[1] - f_ext[i, 1], f[2] - f_ext[i, 2])
        store3(ws.aw, i, aw)
        store3(ws.av, i, al)
        store3(ws.n, i, n)
        store3(ws.f, i, f)
    for i in range(nb - 1, -1, -1):  # tau_i = S_i^T f_i,  f_p += X_i^T f_i
        n, f = load3(ws.n, i), load3(ws.f, i)
        _project_force(tree, i, n, f, tau)
        par = parents[i]
        if par >= 0:
            pn, pf = force_to_parent(load33(d.R, i), load3(d.p, i), n, f)
            store3(ws.n, par, add(load3(ws.n, par), pn))
            store3(ws.f, par, add(load3(ws.f, par), pf))


@kernel
def _rnea_into(tree, q, v, a, gravity, f_ext, ws, tau):
    """RNEA for one state into ``tau`` with every term."""
    _rnea_terms(tree, q, v, a, gravity, f_ext, ws, tau, True, True)


