"""``auto``: rk45 while the problem is not stiff, radau while it is, the way LSODA alternates between Adams
and BDF.  It starts with rk45; when DOPRI5's stiffness test fires (h*|lambda| > 3.25 on 15 accepted steps) it
switches to radau; while on radau it estimates the spectral radius rho of each Jacobian (power iteration) and
switches back when h*rho < 2 (the explicit method would be stable at the same step) on 20 accepted steps in a
row.  Every switch is logged (time, method switched to, reason, the measured value).

Both methods are compiled into auto's entry point (radau's step is about half of its compile time, paid once
per problem type and cached): deferring radau to the first switch needed a call through an address, which
numba's public API does not offer for these argument types.
"""

from typing import NamedTuple

import numpy as np

from ..._numba import generic_inline, kernel
from . import radau, rk45
from .interface import MAX_SWITCHES, RADAU, RK45, SWITCH_NONSTIFF, SWITCH_STIFF

NONSTIFF_HRHO, NONSTIFF_STEPS = 2.0, 20


class Auto(NamedTuple):
    rk45: rk45.RK45
    radau: radau.Radau
    mode: np.ndarray  # (3,) int64: method of the next attempt, method of the last accepted step, the count
    #                   of accepted radau steps in a row with h*rho < 2


@kernel
def make(n):
    return Auto(rk45.make(n), radau.make(n), np.array([RK45, RK45, 0]))


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
    accepted, hnew = radau.attempt(m.radau, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)
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
