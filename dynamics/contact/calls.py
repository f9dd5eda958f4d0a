"""The simulation's calls into contact (:mod:`dynamics.simulation.problem`), each compiled to nothing when the
problem has no contact (its ``contact`` field is None): a run without contact neither compiles nor imports the
narrow phase.  For a :class:`dynamics.contact.resolve.PackedContact` they compile its implementations in
:mod:`.resolve` (imported then)."""

from numba import types
from numba.extending import overload

from .._numba import JIT_OPTIONS


def contact_torques(c, tree, q, v, tau, delta):
    """tau += the generalised contact force; returns the contact power (0.0 without contact).  ``delta``: q's
    chart coordinate around the step's base, by which a robot clear of everything skips the contact code
    (:mod:`dynamics.contact.clearance`), or None where q is not on the step's chart (never skipped)."""
    raise NotImplementedError("contact_torques: compiled code only")


def contact_bias(c, tree, d, pA, delta):
    """After the ABA's first pass (forward pass d, bias forces pA) at the chart coordinate ``delta``: pA -= the
    contact wrenches; returns the contact power (0.0 without contact)."""
    raise NotImplementedError("contact_bias: compiled code only")


def contact_track(c, tree, t, q, v, delta):
    """After an accepted step ending at (t, q, v) (chart coordinate ``delta`` in the step's chart): the largest
    penetration, the time in contact, and the clearance (:mod:`dynamics.contact.clearance`)."""
    raise NotImplementedError("contact_track: compiled code only")


def contact_emit(c, tree, j, q, v):
    """Sample j: keep the active contacts at (q, v) when the run keeps them."""
    raise NotImplementedError("contact_emit: compiled code only")


def contact_jacobian(c, tree, q, v, dq, dv):
    """dv = d tau_c/dv and dq = the stiffness part of d tau_c/dq (tangent space) at (q, v)
    (:mod:`dynamics.contact.force_derivatives`); returns whether the run needs the exact d tau_c/dq (it integrates
    sensitivities: the caller differences it).  Compiled to nothing without contact."""
    raise NotImplementedError("contact_jacobian: compiled code only")


def _no_power(c, tree, q, v, tau, delta):
    return 0.0


def _no_bias(c, tree, d, pA, delta):
    return 0.0


def _no_track(c, tree, t, q, v, delta):  # numba matches an overload's implementation by its parameter names
    return None


def _no_emit(c, tree, j, q, v):
    return None


def contact_rebased(c):
    """The step's base moved off its chart (a projection onto the constraints): the clearance measures the next
    accepted state again (:mod:`dynamics.contact.clearance`).  Nothing without contact."""
    raise NotImplementedError("contact_rebased: compiled code only")


def _no_rebased(c):
    return None


@overload(contact_rebased, jit_options=JIT_OPTIONS, inline="always")
def _ov_contact_rebased(c):
    if isinstance(c, types.NoneType):
        return _no_rebased
    from .resolve import _rebased
    return _rebased


def contact_touched(c):
    """Whether any evaluation found a contact since the last call (which forgets them); False without contact."""
    raise NotImplementedError("contact_touched: compiled code only")


def contact_touchdown(c):
    """True once per episode of contact: at the first call that finds the last accepted state touching since
    it last touched nothing (``auto``'s switch to radau); False without contact."""
    raise NotImplementedError("contact_touchdown: compiled code only")


def _no_touch(c):
    return False


def _no_jacobian(c, tree, q, v, dq, dv):
    return False


@overload(contact_touched, jit_options=JIT_OPTIONS)
def _ov_contact_touched(c):
    if isinstance(c, types.NoneType):
        return _no_touch
    from .resolve import _touched
    return _touched


@overload(contact_jacobian, jit_options=JIT_OPTIONS)
def _ov_contact_jacobian(c, tree, q, v, dq, dv):
    if isinstance(c, types.NoneType):
        return _no_jacobian
    from .resolve import _jacobian
    return _jacobian


@overload(contact_torques, jit_options=JIT_OPTIONS, inline="always")
def _ov_contact_torques(c, tree, q, v, tau, delta):
    if isinstance(c, types.NoneType):
        return _no_power
    from .resolve import _power, _power_on_chart
    return _power if isinstance(delta, types.NoneType) else _power_on_chart


@overload(contact_bias, jit_options=JIT_OPTIONS, inline="always")
def _ov_contact_bias(c, tree, d, pA, delta):
    if isinstance(c, types.NoneType):
        return _no_bias
    from .resolve import _bias
    return _bias


@overload(contact_track, jit_options=JIT_OPTIONS, inline="always")
def _ov_contact_track(c, tree, t, q, v, delta):
    if isinstance(c, types.NoneType):
        return _no_track
    from .resolve import _track
    return _track


@overload(contact_emit, jit_options=JIT_OPTIONS, inline="always")
def _ov_contact_emit(c, tree, j, q, v):
    if isinstance(c, types.NoneType):
        return _no_emit
    from .resolve import _emit
    return _emit


@overload(contact_touchdown, jit_options=JIT_OPTIONS)
def _ov_contact_touchdown(c):
    if isinstance(c, types.NoneType):
        return _no_touch
    from .resolve import _touchdown
    return _touchdown
