"""The inverse of the mass matrix, computed directly in O(n^2) by the articulated-body approach (Carpentier &
Mansard, "Analytical derivatives of rigid body dynamics algorithms", RSS 2018; Pinocchio's computeMinverse).

Column c of M^-1 is the ABA's answer (:mod:`dynamics.aba`) to tau = e_c at v = 0 without gravity; all columns
are run at once.  Everything is expressed in the world frame (motion axes S_i = oX_i S_i^body, inertias about
the world origin), so no per-column spatial transform is needed.  F_i (6 x nv) is the articulated bias force
of the subtree of i (the ABA's p^A), nonzero only in the subtree's columns; A_i (6 x nv) the acceleration:

    backward (leaves in):  U_i = I^A_i S_i,  D_i = S_i^T U_i,
                           M^-1[i, sub(i)] = D_i^-1 (E_i - S_i^T F_i)           (E_i: the identity at i's dofs)
                           I^A_p += I^A_i - U_i D_i^-1 U_i^T,   F_p += F_i + U_i M^-1[i, sub(i)]
    forward (root out):    M^-1[i, c] -= (U_i D_i^-1)^T A_p[:, c],   A_i = A_p + S_i M^-1[i, c]   (c >= i)

sub(i) are the velocity coordinates of the subtree of i, contiguous from i's own (depth-first order).  The
forward pass computes the upper triangle (columns c >= i's first coordinate), the lower is its mirror.
Cost: O(n d) backward (d the depth) and O(n^2) forward.  A joint whose D_i is not positive (it moves no
mass or inertia) makes M singular: the kernel returns that body's index.
"""

import numpy as np

from . import checks
from ._numba import Kernel, kernel
from .errors import InputError
from .kinematics import world_pose
from .parallel import run_chunks
from .spatial import add, cross, inertia_to_parent, load3, load33, rot, spd_inverse, store_inertia6


@kernel
def workspace(nb, nv):
    return (np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((nb, 6, 6)),  # world poses, I^A (world)
            np.empty((nv, 6)), np.empty((nv, 6)), np.empty((nv, 6)),  # S (world), U, U D^-1
            np.empty((nb, 6, 6)), np.empty((nb, nv, 6)),  # D^-1, F then A (per column a 6-vector)
            np.empty(nb, np.int64), np.empty((6, 6)), np.empty((6, 6)))  # subtree sizes, D, scratch


@kernel
def minverse_into(tree, q, ws, Minv):
    """M^-1 (nv, nv) at q into Minv.  Returns -1, or the index of a body whose joint's D is not positive."""
    parents, mass, hs, Ios, S, v_idx, nv_j = tree.parents, tree.mass, tree.h, tree.Io, tree.S, tree.v_idx, tree.nv_j
    oR, op, IA, Sw, U, UD, Dinv, F, nsub, D, scratch = ws
    nb, nv = parents.shape[0], S.shape[0]
    for i in range(nb):  # world poses, motion axes and inertias
        _, _, R, p = world_pose(tree, i, q, oR, op)
        for k in range(v_idx[i], v_idx[i] + nv_j[i]):
            w = rot(R, (S[k, 0], S[k, 1], S[k, 2]))
            v = add(rot(R, (S[k, 3], S[k, 4], S[k, 5])), cross(p, w))
            Sw[k, 0], Sw[k, 1], Sw[k, 2], Sw[k, 3], Sw[k, 4], Sw[k, 5] = w[0], w[1], w[2], v[0], v[1], v[2]
        m = mass[i]
        h, Io = inertia_to_parent(R, p, m, load3(hs, i), load33(Ios, i))
        store_inertia6(IA, i, m, h, Io)  # about the world origin
        nsub[i] = nv_j[i]
    for i in range(nb - 1, -1, -1):
        if parents[i] >= 0:
            nsub[parents[i]] += nsub[i]
    for i in range(nb):
        for c in range(v_idx[i], v_idx[i] + nsub[i]):
            for r in range(6):
                F[i, c, r] = 0.0

    for i in range(nb - 1, -1, -1):  # backward pass
        k0, nj, ns, par = v_idx[i], nv_j[i], nsub[i], parents[i]
        for a in range(nj):
            for r in range(6):
                x = 0.0
                for c in range(6):
                    x += IA[i, r, c] * Sw[k0 + a, c]
                U[k0 + a, r] = x
        for a in range(nj):
            for b in range(nj):
                x = 0.0
                for r in range(6):
                    x += Sw[k0 + a, r] * U[k0 + b, r]
                D[a, b] = x
        if not spd_inverse(D, nj, Dinv, i, scratch):
            return i
        for a in range(nj):
            for r in range(6):
                x = 0.0
                for b in range(nj):
                    x += U[k0 + b, r] * Dinv[i, b, a]
                UD[k0 + a, r] = x
        for c in range(k0, k0 + ns):  # M^-1[i, sub(i)] = D^-1 (E - S^T F)
            for b in range(nj):
                x = 1.0 if c == k0 + b else 0.0
                for r in range(6):
                    x -= Sw[k0 + b, r] * F[i, c, r]
                scratch[0, b] = x
            for a in range(nj):
                x = 0.0
                for b in range(nj):
                    x += Dinv[i, a, b] * scratch[0, b]
                Minv[k0 + a, c] = x
        if par < 0:
            continue
        for r in range(6):  # I^A_p += I^A - U D^-1 U^T
            for c in range(6):
                x = IA[i, r, c]
                for a in range(nj):
                    x -= UD[k0 + a, r] * U[k0 + a, c]
                IA[par, r, c] += x
        for c in range(k0, k0 + ns):  # F_p += F + U M^-1[i, sub(i)]
            for r in range(6):
                x = F[i, c, r]
                for a in range(nj):
                    x += U[k0 + a, r] * Minv[k0 + a, c]
                F[par, c, r] += x

    A = F  # F is spent: its memory holds the accelerations A_i
    for i in range(nb):  # forward pass, columns c >= k0
        k0, nj, ns, par = v_idx[i], nv_j[i], nsub[i], parents[i]
        for c in range(k0, nv):
            for a in range(nj):
                x = Minv[k0 + a, c] if c < k0 + ns else 0.0
                if par >= 0:
                    for r in range(6):
                        x -= UD[k0 + a, r] * A[par, c, r]
                Minv[k0 + a, c] = x
            if ns > nj:  # i has children: they need A_i
                for r in range(6):
                    x = A[par, c, r] if par >= 0 else 0.0
                    for a in range(nj):
                        x += Sw[k0 + a, r] * Minv[k0 + a, c]
                    A[i, c, r] = x
    for r in range(nv):
        for c in range(r + 1, nv):
            Minv[c, r] = Minv[r, c]
    return -1


@kernel
def minverse_batch(tree, Q, out, status):
    """out[b] = M^-1 at Q[b]; status[b] = -1 or a body whose joint makes M singular."""
    ws = workspace(tree.parents.shape[0], tree.S.shape[0])
    for b in range(Q.shape[0]):
        status[b] = minverse_into(tree, Q[b], ws, out[b])


# -- public entry point ----------------------------------------------------------------------------
class _SingularJoint(Exception):
    def __init__(self, body):
        self.body = body


class Checked:
    """A batch kernel ``kernel(tree, *rows, *shared, out, status)`` that reports, per state, -1 or a body whose
    joint makes M singular, wrapped for :func:`~dynamics.parallel.run_chunks` (status is its own per chunk)."""

    def __init__(self, kernel):
        self.kernel = Kernel(kernel)

    def __call__(self, tree, *args):
        status = np.empty(args[-1].shape[0], np.int64)
        self.kernel(tree, *args, status)
        bad = status[status >= 0]
        if bad.size:
            raise _SingularJoint(int(bad[0]))


def run_checked(model, kernel, batched, shared, out, what):
    """run_chunks over a :class:`Checked` kernel; a singular M is an InputError naming the joint."""
    try:
        run_chunks(kernel, model.tree, batched, shared, out)
    except _SingularJoint as e:
        raise InputError(f"{what}: the mass matrix is singular at joint {model.joint_names[e.body]!r}: it moves "
                         f"no mass or inertia (lock it with dynamics.lock_joints, or add mass below it)") from None


_minverse_batch = Checked(minverse_batch)


def inverse_mass_matrix(model, q):
    """M(q)^-1, (nv, nv) or (B, nv, nv), computed directly in O(n^2) (not by inverting M; module docstring).

    Raises InputError naming the joint when M is singular (a joint that moves no mass or inertia)."""
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    out = np.empty((Q.shape[0], model.nv, model.nv))
    run_checked(model, _minverse_batch, (Q,), (), out, "inverse mass matrix")
    return out if batched else out[0]
