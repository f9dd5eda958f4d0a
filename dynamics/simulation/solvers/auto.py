"""``auto``: rk45 while the problem is not stiff, radau while it is, the way LSODA alternates between Adams
and BDF.  It starts with rk45; when DOPRI5's stiffness test fires (h*|lambda| > 3.25 on 15 accepted steps), or
when an accepted state touches something after touching nothing (compliant contact is stiff: its regularised
friction has |lambda| ~ mu f_n / (v_s m), 1e6 1/s on a standing quadruped, where DOPRI5's estimate, made in the
norm of the whole state, stays under its threshold and rk45 crawls at its stability limit), it switches to radau; while on radau it estimates the spectral radius rho of each Jacobian (power iteration) and
switches back when h*rho < 2 (the explicit method would be stable at the same step) on 20 accepted steps in a
row.  Every switch is logged (time, method switched to, reason, the measured value).

The two phases are two steppers, each its method wrapped with its switch test, compiled into two entry points
(:mod:`dynamics.simulation.run`): a switch ends the compiled run with the status ``SWITCHED`` after the accepted
step (samples written, chart re-centred, the proposed next step in ``stats.h``), and the caller resumes from
there with the other entry (:func:`dynamics.simulation.solvers.drive_auto`).  So a run that never turns stiff
compiles and runs rk45 alone: radau's step, about half of a first ``auto`` run's compile time, is compiled only
for a problem that needs it.
"""

from typing import NamedTuple

import numpy as np

from ..._numba import generic_inline, helper, kernel
from . import radau, rk45
from .interface import MAX_SWITCHES, RADAU, RK45, SWITCH_CONTACT, SWITCH_NONSTIFF, SWITCH_STIFF, problem_touchdown

NONSTIFF_HRHO, NONSTIFF_STEPS = 2.0, 20


class AutoRK45(NamedTuple):
    """rk45, asking to switch to radau when its stiffness test fires."""

    rk45: rk45.RK45


class AutoRadau(NamedTuple):
    """radau, asking to switch back to rk45 after NONSTIFF_STEPS accepted steps in a row with h*rho < 2."""

    radau: radau.Radau
    calm: np.ndarray  # (1,) int64: accepted steps in a row with h*rho < NONSTIFF_HRHO


@kernel
def make_rk45(n):
    return AutoRK45(rk45.make(n))


@kernel
def make_radau(n):
    return AutoRadau(radau.make(n), np.zeros(1, np.int64))


@helper
def _log(sw, st, t, to, reason, value):
    """Log a switch in ``sw`` (true) or, past MAX_SWITCHES, not (false).  A helper: as a kernel numba compiled it
    once per pair of literal constants (to, reason) its callers pass."""
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
def attempt_rk45(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    accepted, hnew = rk45.attempt(m.rk45, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)
    c = m.rk45.ctl[0]
    if accepted:
        if c.stiff_event:
            if _log(sw, st, t + h, RADAU, SWITCH_STIFF, c.hlamb):
                st.switch_request = 1
        elif problem_touchdown(p) and _log(sw, st, t, RADAU, SWITCH_CONTACT, t):
            st.switch_request = 1
    return accepted, hnew


@generic_inline
def attempt_radau(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    accepted, hnew = radau.attempt(m.radau, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last)
    rho = m.radau.ctl[0].rho
    if accepted and rho >= 0:
        m.calm[0] = m.calm[0] + 1 if h * rho < NONSTIFF_HRHO else 0
        if m.calm[0] >= NONSTIFF_STEPS and _log(sw, st, t + h, RK45, SWITCH_NONSTIFF, h * rho):
            st.switch_request = 1
            hnew = h
    return accepted, hnew


@generic_inline
def dense_rk45(m, p, t0, h, x, z0, z1, out, st):
    rk45.dense(m.rk45, p, t0, h, x, z0, z1, out, st)


@generic_inline
def dense_radau(m, p, t0, h, x, z0, z1, out, st):
    radau.dense(m.radau, p, t0, h, x, z0, z1, out, st)


@kernel
def order_rk45(m):
    return rk45.ORDER


@kernel
def order_radau(m):
    return radau.ORDER


AutoRK45.attempt, AutoRK45.dense, AutoRK45.order = attempt_rk45, dense_rk45, order_rk45
AutoRadau.attempt, AutoRadau.dense, AutoRadau.order = attempt_radau, dense_radau, order_radau
