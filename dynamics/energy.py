"""Kinetic and potential energy.

    T(q, v) = 1/2 sum_i v_i . I_i v_i          (body velocities v_i from the RNEA forward pass)
    U(q)    = - sum_i m_i g . c_i^world        (c_i^world = p_i + R_i c_i, world pose of body i)

With a fixed base the world is the root link's frame; U is zero when every centre of mass is at height 0
along g.
"""

import numpy as np
from numba import njit

from .joints import add_joint_motion, joint_transform
from .spatial import inertia_times_motion, matmul3, matvec, motion_to_child


@njit(cache=True, nogil=True)
def kinetic_energy_kernel(tree, q, v):
    nb = tree.parents.shape[0]
    R = np.empty((3, 3))
    Rj = np.empty((3, 3))
    p = np.empty(3)
    w = np.zeros((nb, 3))
    vl = np.zeros((nb, 3))
    zero = np.zeros(3)
    n = np.empty(3)
    f = np.empty(3)
    T = 0.0
    for i in range(nb):
        joint_transform(tree, i, q, Rj, R, p)
        par = tree.parents[i]
        if par < 0:
            motion_to_child(R, p, zero, zero, w[i], vl[i])
        else:
            motion_to_child(R, p, w[par], vl[par], w[i], vl[i])
        add_joint_motion(tree, i, v, w[i], vl[i])
        inertia_times_motion(tree.mass[i], tree.h[i], tree.Io[i], w[i], vl[i], n, f)
        T += 0.5 * (w[i, 0] * n[0] + w[i, 1] * n[1] + w[i, 2] * n[2]
                    + vl[i, 0] * f[0] + vl[i, 1] * f[1] + vl[i, 2] * f[2])
    return T


@njit(cache=True, nogil=True)
def potential_energy_kernel(tree, q, gravity):
    nb = tree.parents.shape[0]
    Rw = np.empty((nb, 3, 3))  # world pose of each body
    pw = np.empty((nb, 3))
    R = np.empty((3, 3))
    Rj = np.empty((3, 3))
    p = np.empty(3)
    t = np.empty(3)
    U = 0.0
    for i in range(nb):
        joint_transform(tree, i, q, Rj, R, p)
        par = tree.parents[i]
        if par < 0:
            Rw[i] = R
            pw[i] = p
        else:
            matmul3(Rw[par], R, Rw[i])
            matvec(Rw[par], p, t)
            for r in range(3):
                pw[i, r] = pw[par, r] + t[r]
        matvec(Rw[i], tree.h[i], t)  # m R c
        m = tree.mass[i]
        for r in range(3):
            U -= gravity[r] * (m * pw[i, r] + t[r])
    return U


@njit(cache=True, nogil=True)
def kinetic_energy_batch(tree, Q, V, out):
    for b in range(Q.shape[0]):
        out[b] = kinetic_energy_kernel(tree, Q[b], V[b])


@njit(cache=True, nogil=True)
def potential_energy_batch(tree, Q, gravity, out):
    for b in range(Q.shape[0]):
        out[b] = potential_energy_kernel(tree, Q[b], gravity)


# -- public entry points ---------------------------------------------------------------------------
from . import batch as _b  # noqa: E402


def kinetic_energy(model, q, v):
    """T = 1/2 v^T M(q) v (J): a float, or (B,) for a batch."""
    _b.check_model(model)
    Q, bq = _b.configurations(model, q)
    V, bv = _b.states("v", v, model.nv)
    Q, V = _b.broadcast((("q", Q), ("v", V)))
    B = Q.shape[0]
    out = np.empty(B)
    _b.run_chunks(kinetic_energy_batch, model.tree, (Q, V), (), out)
    return out if (bq or bv) else float(out[0])


def potential_energy(model, q, *, gravity=None):
    """U = -sum m_i g . c_i (J), zero reference at the world origin: a float, or (B,) for a batch."""
    _b.check_model(model)
    Q, bq = _b.configurations(model, q)
    out = np.empty(Q.shape[0])
    _b.run_chunks(potential_energy_batch, model.tree, (Q,), (_b.gravity_vector(model, gravity),), out)
    return out if bq else float(out[0])
