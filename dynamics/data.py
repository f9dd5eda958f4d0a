"""The forward pass's record, and workspaces carved from one buffer (Pinocchio's ``Data``, MuJoCo's
``mjData`` stages): the first pass of RNEA, ABA and the energies is the same recursion, written once here, and
the later passes read its results.

For one state, body i with parent p (Featherstone 2008, eqs. 5.7-5.8 with constant S in body coordinates):

    X_i = (R_i, p_i) = _joint_transform(i, q)        body i in its parent's frame
    v_i = X_i v_p + S_i qd_i                          spatial velocity, body frame
    c_i = v_i x (S_i qd_i)                            velocity-product acceleration

:class:`Data` (nb = number of bodies; every vector in body i's own frame):

=========  ===========  ==========================================================================
field      shape        meaning
=========  ===========  ==========================================================================
R          (nb, 3, 3)   body i's axes in its parent's frame (the parent -> child rotation)
p          (nb, 3)      body i's origin in its parent's frame
w, vl      (nb, 3)      angular velocity of body i; linear velocity of its origin
cw, cv     (nb, 3)      c_i = v_i x (S_i qd_i), angular and linear (zero when v is not computed)
=========  ===========  ==========================================================================

Workspaces are carved from one flat buffer by functions ``*_at(base, o, ...)`` that return the record and the
offset after it; the size of a workspace is the offset a carve reaches from 0 (:func:`size_of` pattern: carve
at address 0, keep the end), so no size or offset is ever computed by hand.  The views have no owner
(:func:`dynamics._numba.float_at`): the buffer outlives them.
"""

from typing import NamedTuple

from ._numba import float_at, inline_kernel, int_at
from .joints import _joint_motion, _joint_transform
from .spatial import add, cross_motion, load3, motion_to_child, store3, store33


class Data(NamedTuple):
    """The forward pass's results for one state (shapes and frames in the module docstring)."""

    R: object
    p: object
    w: object
    vl: object
    cw: object
    cv: object


@inline_kernel
def _take(base, o, shape):
    """The float64 array of ``shape`` at offset ``o`` of the buffer at ``base``, and the offset after it."""
    a = float_at(base, o, shape)
    return a, o + a.size


@inline_kernel
def _take_int(base, o, shape):
    """As :func:`_take`, an int64 array (integer scratch in a float buffer: both are 8 bytes wide)."""
    a = int_at(base, o, shape)
    return a, o + a.size


@inline_kernel
def _data_at(base, o, nb):
    """A :class:`Data` for nb bodies at offset o of the buffer at base, and the offset after it."""
    R, o = _take(base, o, (nb, 3, 3))
    p, o = _take(base, o, (nb, 3))
    w, o = _take(base, o, (nb, 3))
    vl, o = _take(base, o, (nb, 3))
    cw, o = _take(base, o, (nb, 3))
    cv, o = _take(base, o, (nb, 3))
    return Data(R, p, w, vl, cw, cv), o


@inline_kernel
def _forward_body(tree, i, q, v, d, with_v):
    """Body i's step of the forward pass (its parent's is done): stores body i's entries of ``d`` and returns
    them, (R, p, w, vl, cw, cv), so that a pass fused with it (RNEA's, ABA's first) keeps them in registers.
    Without ``with_v`` the velocities are zero and not stored, c_i = 0 is."""
    R, p = _joint_transform(tree, i, q)
    store33(d.R, i, R)
    store3(d.p, i, p)
    zero = (0.0, 0.0, 0.0)
    if not with_v:
        store3(d.cw, i, zero)
        store3(d.cv, i, zero)
        return R, p, zero, zero, zero, zero
    par = tree.parents[i]
    if par < 0:
        w, vl = motion_to_child(R, p, zero, zero)
    else:
        w, vl = motion_to_child(R, p, load3(d.w, par), load3(d.vl, par))
    wJ, vJ = _joint_motion(tree, i, v)
    w, vl = add(w, wJ), add(vl, vJ)
    store3(d.w, i, w)
    store3(d.vl, i, vl)
    cw, cv = cross_motion(w, vl, wJ, vJ)
    store3(d.cw, i, cw)
    store3(d.cv, i, cv)
    return R, p, w, vl, cw, cv
