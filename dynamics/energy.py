"""Kinetic and potential energy.

    T(q, v) = 1/2 sum_i v_i . I_i v_i          (body velocities v_i from the forward pass)
    U(q)    = - sum_i m_i g . c_i^world        (c_i^world = p_i + R_i c_i, world pose of body i)

With a fixed base the world is the root link's frame; U is zero when every centre of mass is at height 0
along g.

:func:`_energy_sums` takes a forward pass already done.  The public functions run the plain forward pass
(poses, and velocities only for T); a simulation evaluates the energy of every sample as it writes it
(:func:`sample_energies`, from the run's ``emit``) with the ABA's first pass and workspace, which its run has
compiled anyway (a kernel of its own cost ~4 s of a first simulate from an empty cache).
"""

import numpy as np

from . import checks
from ._numba import (borrow, address, inline_kernel, keep_alive, kernel)
from .aba import _rigid_body_terms
from .parallel import run_chunks
from .data import _data_at, _forward_pass, _take
from .spatial import add, dot, inertia_times, load3, load33, matmul, rot, store3, store33


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


@kernel
def _energy_batch(tree, Q, V, gravity, kinetic, potential, out):
    """out[b] = (T, U) at (Q[b], V[b]), T only if ``kinetic`` (else 0 and V may have one row), U only if
    ``potential`` (else 0)."""
    # the arguments as views with no owner: no reference counts in the loops (dynamics._numba.borrow)
    tree, Q, V = borrow(tree), borrow(Q), borrow(V)
    gravity, kinetic, potential = borrow(gravity), borrow(kinetic), borrow(potential)
    out = borrow(out)
    nb = tree.parents.shape[0]
    buf = np.empty(_data_at(0, 0, nb)[1] + 12 * nb)
    d, o = _data_at(address(buf), 0, nb)
    Rw, o = _take(address(buf), o, (nb, 3, 3))
    pw, o = _take(address(buf), o, (nb, 3))
    for b in range(Q.shape[0]):
        _forward_pass(tree, Q[b], V[b if kinetic else 0], d, kinetic)
        out[b, 0], out[b, 1] = _energy_sums(tree, d, gravity, kinetic, potential, Rw, pw)
    keep_alive(buf)


# -- public entry points ---------------------------------------------------------------------------
def kinetic_energy(model, q, v):
    """T = 1/2 v^T M(q) v (J): a float, or (B,) for a batch."""
    checks.check_model(model)
    Q, (V,), B, batched = checks.state_batch(model, q, (("v", v, model.nv),))
    out = np.empty((B, 2))
    run_chunks(_energy_batch, model.tree, (Q, V), (np.zeros(3), True, False), out)
    return out[:, 0] if batched else float(out[0, 0])


def potential_energy(model, q, *, gravity=None):
    """U = -sum m_i g . c_i (J), zero reference at the world origin: a float, or (B,) for a batch."""
    checks.check_model(model)
    Q, bq = checks.configurations(model, q)
    out = np.empty((Q.shape[0], 2))
    g = checks.gravity_vector(model, gravity)
    run_chunks(_energy_batch, model.tree, (Q, np.zeros((1, model.nv))), (g, False, True), out)
    return out[:, 1] if bq else float(out[0, 1])
