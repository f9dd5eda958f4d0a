"""Kinetic and potential energy.

    T(q, v) = 1/2 sum_i v_i . I_i v_i          (body velocities v_i from the RNEA forward pass)
    U(q)    = - sum_i m_i g . c_i^world        (c_i^world = p_i + R_i c_i, world pose of body i)

With a fixed base the world is the root link's frame; U is zero when every centre of mass is at height 0
along g.
"""

import numpy as np

from . import checks
from ._numba import Kernel, kernel
from .parallel import run_chunks
from .joints import joint_motion, joint_transform
from .spatial import add, dot, inertia_times, load3, load33, matmul, motion_to_child, rot, store3, store33


@kernel
def kinetic_energy_kernel(tree, q, v):
    parents, mass, hs, Ios = tree.parents, tree.mass, tree.h, tree.Io
    nb = parents.shape[0]
    ws = np.empty((nb, 3))
    vs = np.empty((nb, 3))
    zero = (0.0, 0.0, 0.0)
    T = 0.0
    for i in range(nb):
        R, p = joint_transform(tree, i, q)
        par = parents[i]
        if par < 0:
            w, vl = motion_to_child(R, p, zero, zero)
        else:
            w, vl = motion_to_child(R, p, load3(ws, par), load3(vs, par))
        wJ, vJ = joint_motion(tree, i, v)
        w, vl = add(w, wJ), add(vl, vJ)
        store3(ws, i, w)
        store3(vs, i, vl)
        n, f = inertia_times(mass[i], load3(hs, i), load33(Ios, i), w, vl)
        T += 0.5 * (dot(w, n) + dot(vl, f))
    return T


@kernel
def potential_energy_kernel(tree, q, gravity):
    parents, mass, hs = tree.parents, tree.mass, tree.h
    nb = parents.shape[0]
    Rw = np.empty((nb, 3, 3))  # world pose of each body
    pw = np.empty((nb, 3))
    g = (gravity[0], gravity[1], gravity[2])
    U = 0.0
    for i in range(nb):
        R, p = joint_transform(tree, i, q)
        par = parents[i]
        if par >= 0:
            Rp = load33(Rw, par)
            R, p = matmul(Rp, R), add(load3(pw, par), rot(Rp, p))
        store33(Rw, i, R)
        store3(pw, i, p)
        U -= mass[i] * dot(g, p) + dot(g, rot(R, load3(hs, i)))  # m g . (p + R c)
    return U


@kernel
def kinetic_energy_batch(tree, Q, V, out):
    for b in range(Q.shape[0]):
        out[b] = kinetic_energy_kernel(tree, Q[b], V[b])


@kernel
def potential_energy_batch(tree, Q, gravity, out):
    for b in range(Q.shape[0]):
        out[b] = potential_energy_kernel(tree, Q[b], gravity)


# -- public entry points ---------------------------------------------------------------------------
_kinetic_energy_batch = Kernel(kinetic_energy_batch)
_potential_energy_batch = Kernel(potential_energy_batch)


def kinetic_energy(model, q, v):
    """T = 1/2 v^T M(q) v (J): a float, or (B,) for a batch."""
    checks.check_model(model)
    Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = np.empty(B)
    run_chunks(_kinetic_energy_batch, model.tree, (Q, V), (), out)
    return out if batched else float(out[0])


def potential_energy(model, q, *, gravity=None):
    """U = -sum m_i g . c_i (J), zero reference at the world origin: a float, or (B,) for a batch."""
    checks.check_model(model)
    Q, bq = checks.configurations(model, q)
    out = np.empty(Q.shape[0])
    run_chunks(_potential_energy_batch, model.tree, (Q,), (checks.gravity_vector(model, gravity),), out)
    return out if bq else float(out[0])
