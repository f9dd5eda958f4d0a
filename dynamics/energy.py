"""Kinetic and potential energy.

    T(q, v) = 1/2 sum_i v_i . I_i v_i          (body velocities v_i from the forward pass)
    U(q)    = - sum_i m_i g . c_i^world        (c_i^world = p_i + R_i c_i, world pose of body i)

With a fixed base the world is the root link's frame; U is zero when every centre of mass is at height 0
along g.

The public functions are the core's (``core/energy.cpp``); a simulation evaluates the energy of every sample
as it writes it (:func:`sample_energies`, from the run's ``emit``) with the ABA's first pass and workspace.
"""

import numpy as np

from . import _core, checks
from ._numba import inline_kernel
from .aba import _rigid_body_terms
from .parallel import run
from .spatial import add, dot, inertia_times, load3, load33, matmul, rot, store3, store33


def kinetic_energy(model, q, v):
    """T = 1/2 v^T M(q) v (J): a float, or (B,) for a batch."""
    checks.check_model(model)
    Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = run(_core.energy_batch, model, Q, V, np.zeros(3), True, False, out=np.empty((B, 2)))
    return out[:, 0] if batched else float(out[0, 0])


def potential_energy(model, q, *, gravity=None):
    """U = -sum m_i g . c_i (J), zero reference at the world origin: a float, or (B,) for a batch."""
    checks.check_model(model)
    Q, bq = checks.configurations(model, q)
    g = checks.gravity_vector(model, gravity)
    out = run(_core.energy_batch, model, Q, np.zeros((1, model.nv)), g, False, True, out=np.empty((Q.shape[0], 2)))
    return out[:, 1] if bq else float(out[0, 1])


# -- numba kernels that the simulation still calls (until it moves to the core) --------------------------------

@inline_kernel
def _energy_sums(tree, d, gravity, kinetic, potential, Rw, pw):
    """(T, U) from a forward pass in ``d`` (:class:`~dynamics.data.Data`: T when ``kinetic``, from its body
    velocities; U when ``potential``, from the world poses Rw (nb, 3, 3), pw (nb, 3) composed from its
    transforms); 0 for the one not asked."""
    parents, mass, hs, Ios = tree.parents, tree.mass, tree.h, tree.Io
    g = (gravity[0], gravity[1], gravity[2])
    T = 0.0
    U = 0.0
    for i in range(parents.shape[0]):
        if kinetic:
            w, vl = load3(d.w, i), load3(d.vl, i)
            n, f = inertia_times(mass[i], load3(hs, i), load33(Ios, i), w, vl)
            T += 0.5 * (dot(w, n) + dot(vl, f))
        if potential:
            R, p = load33(d.R, i), load3(d.p, i)
            par = parents[i]
            if par >= 0:
                Rp = load33(Rw, par)
                R, p = matmul(Rp, R), add(load3(pw, par), rot(Rp, p))
            store33(Rw, i, R)
            store3(pw, i, p)
            U -= mass[i] * dot(g, p) + dot(g, rot(R, load3(hs, i)))  # m g . (p + R c)
    return T, U


@inline_kernel
def sample_energies(tree, q, v, gravity, f_ext, ws, out):
    """out[:] = (T, U) at (q, v) with the ABA's first pass into its workspace ws (:class:`~dynamics.aba.Work`;
    the run's external forces f_ext enter the pass's bias forces, which the energies do not read).  U's world
    poses are composed in ws.IA: pass 1 writes I^A = I_i there, and nothing here reads it."""
    nb = tree.parents.shape[0]
    _rigid_body_terms(tree, q, v, f_ext, ws, True)
    flat = ws.IA.reshape(36 * nb)
    Rw = flat[:9 * nb].reshape((nb, 3, 3))
    pw = flat[9 * nb:12 * nb].reshape((nb, 3))
    out[0], out[1] = _energy_sums(tree, ws.d, gravity, True, True, Rw, pw)


