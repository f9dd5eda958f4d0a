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



class Data(NamedTuple):
    """The forward pass's results for one state (shapes and frames in the module docstring)."""

    R: object
    p: object
    w: object
    vl: object
    cw: object
    cv: object

