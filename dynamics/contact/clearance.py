"""The clearance: how far a robot is from touching anything, and a sound bound on how far it has moved since,
so that a robot far from everything runs no contact code in its right-hand side (issue 19: contact on a robot
touching nothing costs <= 10 %).

**Reference.**  At an accepted state the broad phase's bounding volumes are measured: g, the smallest
separation over the candidate pairs (a sphere pair's |c_a - c_b| - r_a - r_b, a sphere above a plane its height
minus r_a: :func:`.narrow_phase._separation`), and each body k's lever L_k, the largest distance from its origin
o_k to a body origin or geometry centre in its subtree.

**Moving.**  The simulation's state is the chart coordinate delta around the configuration q0 at the start of
the step (:mod:`dynamics.configuration`); along the path q(s) = retract(q0, s delta), s in [0, 1], each joint's
body twist is S_k delta_k (revolute, prismatic, and the free, spherical and planar joints' charts alike: a
constant translation of the body origin and a constant rotation about it).  A point x of joint k's subtree
therefore moves with speed at most

    |x'| <= sum_(k on x's path to the root) sum_(i in k's dofs) |delta_i| (|S_w,i| |x - o_k| + |S_v,i|).

Every point that matters (body origins and geometry centres) started within L_k + 2 D0 of o_k, D0 the bound
of the motion since the reference, and separates from it by at most 2 D(s) more, so with

    a = sum_i |delta_i| (|S_w,i| (L_k(i) + 2 D0) + |S_v,i|),     b = 2 sum_i |delta_i| |S_w,i|

the motion since the reference D satisfies D' <= a + b D, whence D(1) <= D0 + a (e^b - 1) / b <= D0 +
a / (1 - b) (b < 1; no bound otherwise).  A pair's separation shrinks by at most 2 D, so while 2 D < g no
bounding volumes overlap and the broad phase, and with it the narrow phase, would find nothing: the right-hand
side skips the pose pass and the broad phase (:func:`apart`).  After each accepted step the step's bound joins
D0 (:func:`advance`); once D0 reaches g / 4 the next accepted state becomes the reference (a pose pass and the
broad phase, as before).  A non-finite delta is never apart.

Nothing changes in the results: the skipped evaluations are exactly those that would have found no contact.
:class:`Clearance` is part of each run's :class:`dynamics.contact.resolve.ContactModel`.
"""

from typing import NamedTuple

import numpy as np

from .._numba import inline_kernel, kernel
from ..spatial import load3
from .narrow_phase import _centre, _separation

#: the bound's safety margins against rounding: relative and absolute (m)
_REL, _ABS = 1e-9, 1e-12
#: D0 beyond this fraction of g: the next accepted state becomes the reference
_RENEW = 0.25


class Clearance(NamedTuple):
    """state (3,): [g, D0, 1 once a reference is set]; lever (nb,) L_k at the reference; sw, sv (nv,) |S_w,i|,
    |S_v,i| of each dof's motion subspace row; dof_body (nv,) int64 the body whose joint owns dof i."""

    state: np.ndarray
    lever: np.ndarray
    sw: np.ndarray
    sv: np.ndarray
    dof_body: np.ndarray


def clearance(model):
    """A :class:`Clearance` for ``model`` with no reference yet (nothing is skipped until the first accepted
    state is measured)."""
    tree, nv = model.tree, model.nv
    S = np.asarray(tree.S, float).reshape(nv, 6)
    dof_body = np.zeros(nv, np.int64)
    for b in range(tree.parents.shape[0]):
        dof_body[tree.v_idx[b]:tree.v_idx[b] + tree.nv_j[b]] = b
    return Clearance(np.zeros(3), np.zeros(tree.parents.shape[0]), np.linalg.norm(S[:, :3], axis=1),
                     np.linalg.norm(S[:, 3:], axis=1), dof_body)


@inline_kernel
def moved(cl, delta):
    """The bound D on how far any body origin or geometry centre is from where it was at the reference, at the
    chart coordinate ``delta`` of the present step (module docstring); inf when the bound does not hold."""
    d0 = cl.state[1]
    a = 0.0
    b = 0.0
    for i in range(delta.shape[0]):
        x = abs(delta[i])
        a += x * (cl.sw[i] * (cl.lever[cl.dof_body[i]] + 2.0 * d0) + cl.sv[i])
        b += x * cl.sw[i]
    b *= 2.0
    if not b < 1.0:  # (also a NaN delta)
        return np.inf
    return d0 + a / (1.0 - b)


@inline_kernel
def apart(cl, delta):
    """True when no candidate pair's bounding volumes can overlap at the chart coordinate ``delta``."""
    return cl.state[2] > 0.0 and 2.0 * moved(cl, delta) * (1.0 + _REL) + _ABS < cl.state[0]


@inline_kernel
def advance(cl, delta):
    """After an accepted step ending at ``delta``: D0 = the bound there; True while it leaves room (D0 < g / 4),
    False when the accepted state must be measured again (:func:`set_reference`)."""
    d = moved(cl, delta)
    cl.state[1] = d
    return cl.state[2] > 0.0 and d * (1.0 + _REL) + _ABS < _RENEW * cl.state[0]


@kernel
def set_reference(cl, S, tree, oR, op):
    """The state whose world poses are (oR, op) becomes the reference: g, the levers, D0 = 0."""
    g = np.inf
    for k in range(S.pair_a.shape[0]):
        g = min(g, _separation(S, S.pair_a[k], S.pair_b[k], oR, op))
    L = cl.lever
    L[:] = 0.0
    parents = tree.parents
    for j in range(parents.shape[0]):  # body origins
        _reach(L, parents, op, j, load3(op, j))
    for m in range(S.body.shape[0]):  # geometry centres
        if S.body[m] >= 0:
            _reach(L, parents, op, S.body[m], _centre(S, m, oR, op))
    cl.state[0] = g
    cl.state[1] = 0.0
    cl.state[2] = 1.0


@inline_kernel
def _reach(L, parents, op, j, x):
    """L_k = max(L_k, |x - o_k|) for body j and each of its ancestors k (x: a point of j's subtree)."""
    k = j
    while k >= 0:
        d0, d1, d2 = x[0] - op[k, 0], x[1] - op[k, 1], x[2] - op[k, 2]
        L[k] = max(L[k], np.sqrt(d0 * d0 + d1 * d1 + d2 * d2))
        k = parents[k]
