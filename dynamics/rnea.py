"""Inverse dynamics by the Recursive Newton-Euler Algorithm (Featherstone 2008, sec. 5.3, Table 5.1).

    tau = M(q) a + C(q, v) v + g(q) - sum_i J_i^T f_ext_i

Body-frame formulation.  Gravity enters as a fictitious upward acceleration of the world, a_0 = (0, -g).
Forward pass, for each body i with parent p and joint velocity v_J = S_i qd_i:

    v_i = X_i v_p + S_i qd_i
    a_i = X_i a_p + S_i qdd_i + v_i x (S_i qd_i)
    f_i = I_i a_i + v_i x* I_i v_i - f_ext_i

Backward pass:  tau_i = S_i^T f_i ,  f_p += X_i^T f_i .
"""

import numpy as np
from numba import njit

from .joints import add_joint_motion, joint_transform, project_force
from .spatial import (add_cross_force, add_cross_motion, add_force_to_parent, inertia_times_motion,
                      motion_to_child)


@njit(cache=True, nogil=True)
def workspace(nb):
    """Scratch for one state: poses (R, p), velocities (w, v), accelerations (aw, av), forces (n, f)."""
    return (np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)),
            np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((nb, 3)), np.empty((3, 3)),
            np.empty(3), np.empty(3))


@njit(cache=True, nogil=True)
def rnea_into(tree, q, v, a, gravity, f_ext, ws, tau):
    """RNEA for one state into ``tau``; ``f_ext`` is (nb, 6) [force, torque] per body or (0, 6)."""
    R, p, w, vl, aw, al, n, f, Rj, wJ, vJ = ws
    zero = np.zeros(3)
    minus_g = -gravity
    nb = tree.parents.shape[0]
    for i in range(nb):
        joint_transform(tree, i, q, Rj, R[i], p[i])
        par = tree.parents[i]
        if par < 0:
            motion_to_child(R[i], p[i], zero, zero, w[i], vl[i])
            motion_to_child(R[i], p[i], zero, minus_g, aw[i], al[i])
        else:
            motion_to_child(R[i], p[i], w[par], vl[par], w[i], vl[i])
            motion_to_child(R[i], p[i], aw[par], al[par], aw[i], al[i])
        wJ[:] = 0.0
        vJ[:] = 0.0
        add_joint_motion(tree, i, v, wJ, vJ)
        for r in range(3):
            w[i, r] += wJ[r]
            vl[i, r] += vJ[r]
        add_joint_motion(tree, i, a, aw[i], al[i])
        add_cross_motion(w[i], vl[i], wJ, vJ, aw[i], al[i])
        # f_i = I a + v x* I v
        inertia_times_motion(tree.mass[i], tree.h[i], tree.Io[i], aw[i], al[i], n[i], f[i])
        inertia_times_motion(tree.mass[i], tree.h[i], tree.Io[i], w[i], vl[i], wJ, vJ)  # wJ, vJ reused: I v
        add_cross_force(w[i], vl[i], wJ, vJ, n[i], f[i])
        if f_ext.shape[0] > 0:
            for r in range(3):
                f[i, r] -= f_ext[i, r]
                n[i, r] -= f_ext[i, 3 + r]
    for i in range(nb - 1, -1, -1):
        project_force(tree, i, n[i], f[i], tau)
        par = tree.parents[i]
        if par >= 0:
            add_force_to_parent(R[i], p[i], n[i], f[i], n[par], f[par])


@njit(cache=True, nogil=True)
def rnea(tree, q, v, a, gravity, f_ext):
    """Joint torques for one state (allocates its own workspace; callable from other kernels)."""
    tau = np.empty(tree.S.shape[0])
    rnea_into(tree, q, v, a, gravity, f_ext, workspace(tree.parents.shape[0]), tau)
    return tau


@njit(cache=True, nogil=True)
def rnea_batch(tree, Q, V, A, F, gravity, out):
    """Rows of ``out`` = RNEA of the rows of Q, V, A; F is (1 or B, nb or 0, 6)."""
    ws = workspace(tree.parents.shape[0])
    last = F.shape[0] - 1
    for b in range(Q.shape[0]):
        rnea_into(tree, Q[b], V[b], A[b], gravity, F[min(b, last)], ws, out[b])


# -- public entry points ---------------------------------------------------------------------------
from . import batch as _b  # noqa: E402


def _run(model, q, v, a, gravity, f_ext):
    _b.check_model(model)
    Q, batched = _b.configurations(model, q)
    V, bv = _b.states("v", v, model.nv)
    A, ba = _b.states("a", a, model.nv)
    Q, V, A = _b.broadcast((("q", Q), ("v", V), ("a", A)))
    B = Q.shape[0]
    batched = batched or bv or ba
    out = np.empty((B, model.nv))
    F = _b.external_forces(model, f_ext, B)
    g = _b.gravity_vector(model, gravity)
    _b.run_chunks(rnea_batch, model.tree, (Q, V, A, F), (g,), out)
    return out if batched else out[0]


def inverse_dynamics(model, q, v, a, *, gravity=None, f_ext=None):
    """Joint torques tau = M(q) a + C(q, v) v + g(q) - J^T f_ext (RNEA).

    q: (nq,) or (B, nq); v, a: (nv,) or (B, nv); gravity: (3,) in the world frame (default model.gravity);
    f_ext: (nbodies, 6) or (B, nbodies, 6), one [force, torque] per body in its body frame, torque about the
    body frame origin.  Returns tau of shape (nv,) or (B, nv).
    """
    return _run(model, q, v, a, gravity, f_ext)


def gravity_torques(model, q, *, gravity=None):
    """g(q): the torques that hold the robot still against gravity, (nv,) or (B, nv)."""
    zeros = np.zeros(model.nv)
    return _run(model, q, zeros, zeros, gravity, None)


def bias_forces(model, q, v, *, gravity=None):
    """C(q, v) v + g(q): inverse dynamics at zero acceleration, (nv,) or (B, nv)."""
    return _run(model, q, v, np.zeros(model.nv), gravity, None)
