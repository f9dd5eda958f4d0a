"""``auto``: rk45 while the problem is not stiff, radau while it is, the way LSODA alternates between Adams
and BDF.  It starts with rk45; when DOPRI5's stiffness test fires (h*|lambda| > 3.25 on 15 accepted steps) it
switches to radau; while on radau it estimates the spectral radius rho of each Jacobian (power iteration) and
switches back when h*rho < 2 (the explicit method would be stable at the same step) on 20 accepted steps in a
row.  Every switch is logged (time, method switched to, reason, the measured value).

**Radau compiled at the first switch.**  Most runs never switch, and radau's step (a finite-difference
Jacobian, two LU factorisations, the Newton iteration: about half of auto's compile time) would be compiled
for nothing.  For a problem behind a :class:`~.interface.Handle` (the library's simulations), ``attempt`` calls
radau's step through an address (:func:`radau_attempt`, compiled and cached on its own, for fixed types), and
takes that address on the first radau step only, from Python (:func:`_load_radau`, numba's ``objmode``):
compiled, or loaded from the cache, then.  The arithmetic is the same, so are the results.  A plain problem
(the solvers' own tests) inlines radau's step as before.
"""

from typing import NamedTuple

import numpy as np
from numba import objmode, typeof, types
from numba.core.errors import TypingError
from numba.extending import intrinsic, overload

from ..._numba import JIT_OPTIONS, call_address, generic_inline, gil_kernel, kernel, native_address
from . import radau, rk45
from .interface import MAX_SWITCHES, RADAU, RK45, SWITCH_NONSTIFF, SWITCH_STIFF, Handle

NONSTIFF_HRHO, NONSTIFF_STEPS = 2.0, 20


class Auto(NamedTuple):
    rk45: rk45.RK45
    radau: radau.Radau
    mode: np.ndarray  # (3,) int64: method of the next attempt, method of the last accepted step, the count
    #                   of accepted radau steps in a row with h*rho < 2
    radau_fn: np.ndarray  # (1,) int64: address of radau_attempt for this run's types, 0 until the first radau step


@kernel
def make(n):
    return Auto(rk45.make(n), radau.make(n), np.array([RK45, RK45, 0]), np.zeros(1, np.int64))


# ---------------------------------------------------------------------------------------------------
# radau's step behind an address, compiled at the first switch (module docstring)
@kernel
def radau_attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    """radau.attempt compiled on its own (cached), for ``auto``'s call through an address."""
    return radau.attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)


_VEC = types.float64[::1]
_STEP = types.Tuple((types.boolean, types.float64))


def _attempt_signature(m, p, z, opt, st, sw):
    """The signature radau_attempt is compiled for, from the values of a call (their numba types)."""
    vec = typeof(z)
    return _STEP(typeof(m), typeof(p), types.float64, types.float64, vec, vec, vec, vec, vec, vec, typeof(opt),
                 typeof(st), typeof(sw), types.boolean)


def _radau_address(fn, m, p, z, opt, st, sw):
    """fn[0] = the address of radau_attempt compiled (or loaded from the cache) for these values' types."""
    fn[0] = native_address(radau_attempt, _attempt_signature(m, p, z, opt, st, sw))


@gil_kernel  # objmode takes the GIL
def _load_radau(fn, m, p, z, opt, st, sw):
    with objmode():
        _radau_address(fn, m, p, z, opt, st, sw)


@intrinsic
def _call_radau(typingctx, fn, m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    """radau_attempt(m, p, ...) through the address fn (compiled by :func:`_load_radau` for these types)."""
    argtys = (m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)
    want = (types.float64, types.float64) + (z,) * 6
    if (t, h, z, f0, znew, fnew, errv, mag) != want or z != _VEC or rejected_last != types.boolean:
        raise TypingError(f"auto: radau's step through an address expects float64 times, C-contiguous float64 "
                          f"state vectors and a bool, got {argtys}")
    callee = _STEP(*argtys)

    def codegen(context, builder, sig, args):
        return call_address(context, builder, context.cast(builder, args[0], fn, types.int64), callee, args[1:])
    return _STEP(fn, *argtys), codegen


def _radau_step(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    """radau's attempt within auto (compiled code only): through an address for a Handle (module docstring)."""
    raise NotImplementedError


@overload(_radau_step, jit_options=JIT_OPTIONS)
def _ov_radau_step(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    if getattr(p, "instance_class", None) is not Handle:
        return lambda m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last: radau.attempt(
            m.radau, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)

    def deferred(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
        if m.radau_fn[0] == 0:
            _load_radau(m.radau_fn, m.radau, p, z, opt, st, sw)
        return _call_radau(m.radau_fn[0], m.radau, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw,
                           rejected_last)
    return deferred


@kernel
def _log(sw, st, t, to, reason, value):
    if st.switches < MAX_SWITCHES:
        s = sw[st.switches]
        s.t = t
        s.to = to
        s.reason = reason
        s.value = value
        st.switches += 1
        return True
    return False


@generic_inline
def attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    mode = m.mode
    if mode[0] == RK45:
        accepted, hnew = rk45.attempt(m.rk45, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)
        if accepted:
            mode[1] = RK45
            c = m.rk45.ctl[0]
            if c.stiff_event and _log(sw, st, t + h, RADAU, SWITCH_STIFF, c.hlamb):
                mode[0] = RADAU
                mode[2] = 0
                radau.reset(m.radau)
        return accepted, hnew
    accepted, hnew = _radau_step(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)
    rho = m.radau.ctl[0].rho
    if accepted:
        mode[1] = RADAU
        if rho >= 0:
            mode[2] = mode[2] + 1 if h * rho < NONSTIFF_HRHO else 0
            if mode[2] >= NONSTIFF_STEPS and _log(sw, st, t + h, RK45, SWITCH_NONSTIFF, h * rho):
                mode[0] = RK45
                rk45.reset(m.rk45)
                m.radau.ctl[0].need_jac = 1
                hnew = h
    return accepted, hnew


@generic_inline
def dense(m, p, t0, h, x, z0, z1, out, st):
    if m.mode[1] == RK45:
        rk45.dense(m.rk45, p, t0, h, x, z0, z1, out, st)
    else:
        radau.dense(m.radau, p, t0, h, x, z0, z1, out, st)


@kernel
def order(m):
    return rk45.ORDER if m.mode[0] == RK45 else radau.ORDER


Auto.attempt = attempt
Auto.dense = dense
Auto.order = order
