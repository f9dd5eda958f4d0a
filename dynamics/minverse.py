"""The inverse of the mass matrix, computed directly in O(n^2) by the articulated-body approach (Carpentier &
Mansard, "Analytical derivatives of rigid body dynamics algorithms", RSS 2018; Pinocchio's computeMinverse).

Column c of M^-1 is the ABA's answer (:mod:`dynamics.aba`) to tau = e_c at v = 0 without gravity; all columns
are run at once.  Everything is expressed in the world frame (motion axes S_i = oX_i S_i^body, inertias about
the world origin), so no per-column spatial transform is needed.  F_i (6 x nv, kept as one 6-vector per
column) is the articulated bias force of the subtree of i (the ABA's p^A), nonzero only in the subtree's
columns; A_i (6 x nv, same storage) the acceleration:

    backward (leaves in):  U_i = I^A_i S_i,  D_i = S_i^T U_i,
                           M^-1[i, sub(i)] = D_i^-1 (E_i - S_i^T F_i)           (E_i: the identity at i's dofs)
                           I^A_p += I^A_i - U_i D_i^-1 U_i^T,   F_p += F_i + U_i M^-1[i, sub(i)]

(the children's sub(i) are disjoint, so F_p on sub(i) is simply set from child i, and F_i is zero at i's own
columns, never stored: F needs no clearing)
    forward (root out):    M^-1[i, c] -= (U_i D_i^-1)^T A_p[:, c],   A_i = A_p + S_i M^-1[i, c]   (c >= i)

sub(i) are the velocity coordinates of the subtree of i, contiguous from i's own (depth-first order).  The
forward pass computes the upper triangle (columns c >= i's first coordinate), the lower is its mirror.
Cost: O(n d) backward (d the depth) and O(n^2) forward.  A joint whose D_i is not positive (it moves no
mass or inertia) makes M singular: the kernel returns that body's index.  1-dof joints (nearly all) take
loops specialised with their 6-vectors in locals; the free joint the generic ones.

The algorithm is the core's (``core/minverse.cpp``); this module checks the arguments and calls it.
"""

import numpy as np

from . import _core, checks
from ._numba import helper, inline_kernel, kernel
from .data import _take, _take_int
from .kinematics import _world_pose
from .parallel import run, run_chunks
from .spatial import add, cross, inertia_to_parent, _joint_gram, load3, load33, rot, _spd_inverse, _store_inertia6


def inverse_mass_matrix(model, q):
    """M(q)^-1, (nv, nv) or (B, nv, nv), computed directly in O(n^2) (not by inverting M; module docstring).

    Raises InputError naming the joint when M is singular (a joint that moves no mass or inertia)."""
    try:  # one state: one core call, which checks q (anything else takes the general path)
        Minv = _core.inverse_mass_matrix(model.core, q)
        if Minv is not None:
            return Minv
    except checks.NOT_A_MODEL:
        pass
    checks.check_model(model)
    Q, batched = checks.configurations(model, q)
    out = run(_core.minverse_batch, model, Q, out=np.empty((Q.shape[0], model.nv, model.nv)),
              singular="inverse mass matrix")
    return out if batched else out[0]


# -- numba kernels that the derivatives and the operational-space controller still call (until they move to the
# core) ----------------------------------------------------------------------------------------------------------

@helper
def _workspace(nb, nv):
    return (np.empty((nb, 3, 3)), np.empty((nb, 3)), np.empty((nb, 6, 6)),  # world poses, I^A (world)
            np.empty((nv, 6)), np.empty((nv, 6)), np.empty((nv, 6)),  # S (world), U, U D^-1
            np.empty((nb, 6, 6)), np.empty((nb, nv, 6)),  # D^-1, F then A (per column a 6-vector)
            np.empty(nb, np.int64), np.empty((6, 6)), np.empty((6, 6)))  # subtree sizes, D, scratch


@inline_kernel
def _work_at(base, o, nb, nv):
    """The same scratch carved from the buffer at ``base`` from offset o, and the offset after it."""
    oR, o = _take(base, o, (nb, 3, 3))
    op, o = _take(base, o, (nb, 3))
    IA, o = _take(base, o, (nb, 6, 6))
    Sw, o = _take(base, o, (nv, 6))
    U, o = _take(base, o, (nv, 6))
    UD, o = _take(base, o, (nv, 6))
    Dinv, o = _take(base, o, (nb, 6, 6))
    F, o = _take(base, o, (nb, nv, 6))
    nsub, o = _take_int(base, o, nb)
    D, o = _take(base, o, (6, 6))
    scratch, o = _take(base, o, (6, 6))
    return (oR, op, IA, Sw, U, UD, Dinv, F, nsub, D, scratch), o


@kernel
def _minverse_into(tree, q, ws, Minv):
    """M^-1 (nv, nv) at q into Minv.  Returns -1, or the index of a body whose joint's D is not positive."""
    parents, mass, hs, Ios, S, v_idx, nv_j = tree.parents, tree.mass, tree.h, tree.Io, tree.S, tree.v_idx, tree.nv_j
    oR, op, IA, Sw, U, UD, Dinv, F, nsub, D, scratch = ws
    nb, nv = parents.shape[0], S.shape[0]
    for i in range(nb):  # world poses, motion axes and inertias
        _, _, R, p = _world_pose(tree, i, q, oR, op)
        for k in range(v_idx[i], v_idx[i] + nv_j[i]):
            w = rot(R, (S[k, 0], S[k, 1], S[k, 2]))
            v = add(rot(R, (S[k, 3], S[k, 4], S[k, 5])), cross(p, w))
            Sw[k, 0], Sw[k, 1], Sw[k, 2], Sw[k, 3], Sw[k, 4], Sw[k, 5] = w[0], w[1], w[2], v[0], v[1], v[2]
        m = mass[i]
        h, Io = inertia_to_parent(R, p, m, load3(hs, i), load33(Ios, i))
        _store_inertia6(IA, i, m, h, Io)  # about the world origin
        nsub[i] = nv_j[i]
    for i in range(nb - 1, -1, -1):
        if parents[i] >= 0:
            nsub[parents[i]] += nsub[i]

    for i in range(nb - 1, -1, -1):  # backward pass
        if not _backward_body(IA, Sw, U, UD, Dinv, F, Minv, D, scratch, i, v_idx[i], nv_j[i], nsub[i], parents[i]):
            return i
    A = F  # F is spent: its memory holds the accelerations A_i
    for i in range(nb):  # forward pass, columns c >= k0
        _forward_body(Sw, UD, A, Minv, i, v_idx[i], nv_j[i], nsub[i], parents[i], nv)
    for r in range(nv):
        for c in range(r + 1, nv):
            Minv[c, r] = Minv[r, c]
    return -1


@inline_kernel
def _backward_body(IA, Sw, U, UD, Dinv, F, Minv, D, scratch, i, k0, nj, ns, par):
    """The backward pass at body i (its children done): U, D^-1, U D^-1, its rows of M^-1, F_p and I^A_p.
    False when D is not positive (the joint moves no mass or inertia)."""
    if nj == 1:  # the common joint, with its 6-vectors in locals
        return _backward_1dof_body(IA, Sw, U, UD, Dinv, F, Minv, i, k0, ns, par)
    for a in range(nj):
        for r in range(6):
            x = 0.0
            for c in range(6):
                x += IA[i, r, c] * Sw[k0 + a, c]
            U[k0 + a, r] = x
    _joint_gram(Sw, U, k0, nj, D)  # D = S^T U
    if not _spd_inverse(D, nj, Dinv, i, scratch):
        return False
    for a in range(nj):
        for r in range(6):
            x = 0.0
            for b in range(nj):
                x += U[k0 + b, r] * Dinv[i, b, a]
            UD[k0 + a, r] = x
    _backward_columns(Sw, U, Dinv, F, Minv, scratch, i, k0, nj, ns, par)
    if par >= 0:
        for r in range(6):  # I^A_p += I^A - U D^-1 U^T
            for c in range(6):
                x = IA[i, r, c]
                for a in range(nj):
                    x -= UD[k0 + a, r] * U[k0 + a, c]
                IA[par, r, c] += x
    return True


@inline_kernel
def _forward_body(Sw, UD, A, Minv, i, k0, nj, ns, par, nv):
    """The forward pass at body i (its parent done): its rows of M^-1 from column k0 on, and A_i if it has
    children."""
    if nj == 1:
        _forward_1dof(Sw, UD, A, Minv, i, k0, ns, par, nv)
        return
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


@inline_kernel
def _backward_columns(Sw, U, Dinv, F, Minv, scratch, i, k0, nj, ns, par):
    """M^-1[i, sub(i)] = D^-1 (E - S^T F_i), then F_p = F_i + U M^-1[i, sub(i)] on sub(i) (any joint; F_i is
    zero at i's own columns, which F does not hold)."""
    for c in range(k0, k0 + ns):
        own = c < k0 + nj
        for b in range(nj):
            x = 1.0 if c == k0 + b else 0.0
            if not own:
                for r in range(6):
                    x -= Sw[k0 + b, r] * F[i, c, r]
            scratch[0, b] = x
        for a in range(nj):
            x = 0.0
            for b in range(nj):
                x += Dinv[i, a, b] * scratch[0, b]
            Minv[k0 + a, c] = x
    if par >= 0:
        for c in range(k0, k0 + ns):
            own = c < k0 + nj
            for r in range(6):
                x = 0.0 if own else F[i, c, r]
                for a in range(nj):
                    x += U[k0 + a, r] * Minv[k0 + a, c]
                F[par, c, r] = x


@inline_kernel
def _vec6(A, k):
    return A[k, 0], A[k, 1], A[k, 2], A[k, 3], A[k, 4], A[k, 5]


@inline_kernel
def _backward_1dof_body(IA, Sw, U, UD, Dinv, F, Minv, i, k0, ns, par):
    """The backward pass at a 1-dof joint: U = I^A s, D = s . U, its row of M^-1, F_p and I^A_p.  False when D
    is not positive."""
    s0, s1, s2, s3, s4, s5 = _vec6(Sw, k0)
    for r in range(6):
        U[k0, r] = (IA[i, r, 0] * s0 + IA[i, r, 1] * s1 + IA[i, r, 2] * s2 + IA[i, r, 3] * s3
                    + IA[i, r, 4] * s4 + IA[i, r, 5] * s5)
    u0, u1, u2, u3, u4, u5 = _vec6(U, k0)
    d = s0 * u0 + s1 * u1 + s2 * u2 + s3 * u3 + s4 * u4 + s5 * u5
    if not d > 0.0:
        return False
    dinv = 1.0 / d
    _set_entry(Dinv, i, dinv)
    UD[k0, 0], UD[k0, 1], UD[k0, 2] = u0 * dinv, u1 * dinv, u2 * dinv
    UD[k0, 3], UD[k0, 4], UD[k0, 5] = u3 * dinv, u4 * dinv, u5 * dinv
    _backward_1dof(Sw, U, dinv, F, Minv, i, k0, ns, par)
    if par >= 0:  # I^A_p += I^A - U U^T / D
        for r in range(6):
            x = UD[k0, r]
            IA[par, r, 0] += IA[i, r, 0] - x * u0
            IA[par, r, 1] += IA[i, r, 1] - x * u1
            IA[par, r, 2] += IA[i, r, 2] - x * u2
            IA[par, r, 3] += IA[i, r, 3] - x * u3
            IA[par, r, 4] += IA[i, r, 4] - x * u4
            IA[par, r, 5] += IA[i, r, 5] - x * u5
    return True


@helper
def _set_entry(Dinv, i, x):
    """Dinv[i, 0, 0] = x, through a helper: this kernel is inlined into the fused ABA derivatives, which read
    Dinv later in another inlined kernel, and numba's dead-code elimination there dropped the bare assignment
    to the workspace view (the value read was the buffer's garbage)."""
    Dinv[i, 0, 0] = x


@inline_kernel
def _backward_1dof(Sw, U, dinv, F, Minv, i, k0, ns, par):
    """_backward_columns for a 1-dof joint, one pass over the columns with S and U held in locals."""
    s0, s1, s2, s3, s4, s5 = _vec6(Sw, k0)
    u0, u1, u2, u3, u4, u5 = _vec6(U, k0)
    Minv[k0, k0] = dinv
    if par >= 0:  # F_i is zero at i's own column
        F[par, k0, 0], F[par, k0, 1], F[par, k0, 2] = u0 * dinv, u1 * dinv, u2 * dinv
        F[par, k0, 3], F[par, k0, 4], F[par, k0, 5] = u3 * dinv, u4 * dinv, u5 * dinv
    for c in range(k0 + 1, k0 + ns):
        f0, f1, f2, f3, f4, f5 = F[i, c, 0], F[i, c, 1], F[i, c, 2], F[i, c, 3], F[i, c, 4], F[i, c, 5]
        x = -dinv * (s0 * f0 + s1 * f1 + s2 * f2 + s3 * f3 + s4 * f4 + s5 * f5)
        Minv[k0, c] = x
        if par >= 0:
            F[par, c, 0], F[par, c, 1], F[par, c, 2] = f0 + u0 * x, f1 + u1 * x, f2 + u2 * x
            F[par, c, 3], F[par, c, 4], F[par, c, 5] = f3 + u3 * x, f4 + u4 * x, f5 + u5 * x


@inline_kernel
def _forward_1dof(Sw, UD, A, Minv, i, k0, ns, par, nv):
    """The forward pass's row of a 1-dof joint: M^-1[i, c] -= (U/D) . A_p[c], A_i[c] = A_p[c] + S M^-1[i, c]."""
    s0, s1, s2, s3, s4, s5 = _vec6(Sw, k0)
    d0, d1, d2, d3, d4, d5 = _vec6(UD, k0)
    children = ns > 1
    for c in range(k0, nv):
        x = Minv[k0, c] if c < k0 + ns else 0.0
        if par >= 0:
            a0, a1, a2, a3, a4, a5 = A[par, c, 0], A[par, c, 1], A[par, c, 2], A[par, c, 3], A[par, c, 4], A[par, c, 5]
            x -= d0 * a0 + d1 * a1 + d2 * a2 + d3 * a3 + d4 * a4 + d5 * a5
        else:
            a0 = a1 = a2 = a3 = a4 = a5 = 0.0
        Minv[k0, c] = x
        if children:  # they need A_i
            A[i, c, 0], A[i, c, 1], A[i, c, 2] = a0 + s0 * x, a1 + s1 * x, a2 + s2 * x
            A[i, c, 3], A[i, c, 4], A[i, c, 5] = a3 + s3 * x, a4 + s4 * x, a5 + s5 * x


class _SingularJoint(Exception):
    def __init__(self, body):
        self.body = body


class Checked:
    """A batch kernel ``kernel(tree, *rows, *shared, out, status)`` that reports, per state, -1 or a body whose
    joint makes M singular, wrapped for :func:`~dynamics.parallel.run_chunks` (status is its own per chunk)."""

    def __init__(self, kernel):
        self.kernel = kernel

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
        raise checks.singular_joint_error(model, e.body, what) from None


