"""Dormand & Prince 5(4) with local extrapolation, FSAL, the PI step-size controller of DOPRI5 ([HNW] sec.
IV.2, beta = 0.04), Shampine's quartic dense output, and DOPRI5's stiffness test ([HW] sec. IV.2: h*|lambda|
estimated from the last two stages exceeds 3.25 on 15 accepted steps).

[HNW] = Hairer, Norsett & Wanner, "Solving ODEs I", 2nd ed. 1993; [HW] = Hairer & Wanner, "Solving ODEs II".
"""

from typing import NamedTuple

import numpy as np

from ..._numba import copy_into, generic_inline, kernel
from .interface import OK, problem_rhs
from .linalg import scaled_rms, state_status

ORDER = 5
STABILITY_LIMIT = 3.3  # |h lambda| on the negative real axis
STIFF_HLAMBDA, STIFF_STEPS = 3.25, 15

# Dormand-Prince 5(4) tableau, error weights and dense-output polynomial ([HNW] table II.5.2; Shampine 1986)
DP_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
DP_A = np.array([
    [0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0],
    [44 / 45, -56 / 15, 32 / 9, 0, 0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656]])
DP_B = np.array([35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
DP_A7 = np.zeros((7, 6))  # A with the weights as 7th row: the last stage is the new point (FSAL)
DP_A7[:6, :5] = DP_A
DP_A7[6, :] = DP_B
DP_C7 = np.append(DP_C, 1.0)
DP_E = np.array([-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40])
DP_P = np.array([
    [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
    [0, 0, 0, 0],
    [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
    [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
    [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
    [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
    [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423]])

CTL = np.dtype([("errold", np.float64), ("iasti", np.int64), ("nonsti", np.int64), ("stiff_event", np.int64),
                ("hlamb", np.float64)], align=True)


class RK45(NamedTuple):
    K: np.ndarray  # (7, n) stages; K[0] = f(t, z), K[6] = f at the new point (FSAL)
    y6: np.ndarray  # (n,) the 6th stage's state (stiffness test)
    ctl: np.ndarray  # (1,) CTL: the PI controller's memory and the stiffness-test counters


@kernel
def make(n):
    ctl = np.zeros(1, CTL)
    ctl[0].errold = 1e-4
    return RK45(np.empty((7, n)), np.empty(n), ctl)


@kernel
def reset(m):
    """Fresh controller memory (``auto`` switching back to this method)."""
    c = m.ctl[0]
    c.errold = 1e-4
    c.iasti = 0
    c.nonsti = 0


@generic_inline
def attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, sw, rejected_last):
    """One Dormand-Prince step: stages 2-7 (stage 7 is the new point, FSAL), the PI controller, the
    stiffness test.  Returns (accepted, next h)."""
    K, y6, c = m.K, m.y6, m.ctl[0]
    n = z.shape[0]
    copy_into(K[0], f0)
    for s in range(1, 7):
        for r in range(n):
            acc = 0.0
            for q in range(s):
                acc += DP_A7[s, q] * K[q, r]
            znew[r] = z[r] + h * acc
        if s == 5:
            copy_into(y6, znew)
        problem_rhs(p, t + DP_C7[s] * h, znew, K[s])
    st.rhs_evals += 6
    for r in range(n):
        acc = 0.0
        for q in range(7):
            acc += DP_E[q] * K[q, r]
        errv[r] = h * acc
    err = scaled_rms(errv, z, znew, mag, opt.ne, opt.rtol, opt.atol)
    c.stiff_event = 0
    if not np.isfinite(err) or state_status(K[6], 0, 0, np.inf) != OK:
        return False, h * 0.1
    fac11 = err ** (0.2 - 0.04 * 0.75)  # PI step-size control ([HNW] IV.2, DOPRI5 with beta = 0.04)
    if err > 1.0:
        return False, h / min(5.0, fac11 / 0.9)
    fac = max(0.1, min(5.0, fac11 / c.errold ** 0.04 / 0.9))  # 1/fac in [0.2, 10]
    c.errold = max(err, 1e-4)
    hnew = min(h / fac, h) if rejected_last else h / fac
    copy_into(fnew, K[6])
    _stiffness_test(m, h, znew, opt.ne, t + h, st)
    return True, hnew


@kernel
def _stiffness_test(m, h, znew, ne, tn, st):
    """DOPRI5's test: h |lambda| ~ h ||k7 - k6|| / ||y7 - y6|| above 3.25 on 15 accepted steps (6 steps
    below reset the count).  Sets ``ctl.stiff_event`` on the 15th."""
    K, y6, c = m.K, m.y6, m.ctl[0]
    stnum = 0.0
    stden = 0.0
    for r in range(ne):
        stnum += (K[6, r] - K[5, r]) ** 2
        stden += (znew[r] - y6[r]) ** 2
    if stden <= 0.0:
        return
    hlamb = h * np.sqrt(stnum / stden)
    if hlamb > STIFF_HLAMBDA:
        c.nonsti = 0
        c.iasti += 1
        st.stiff_hits += 1
        if c.iasti == STIFF_STEPS:
            c.stiff_event = 1
            c.hlamb = hlamb
            if not st.stiff_t >= 0:
                st.stiff_t = tn
    else:
        c.nonsti += 1
        if c.nonsti == 6:
            c.iasti = 0


@generic_inline
def dense(m, p, t0, h, x, z0, z1, out, st):
    """Shampine's quartic through the stages of the last accepted step."""
    K = m.K
    b0 = x * (DP_P[0, 0] + x * (DP_P[0, 1] + x * (DP_P[0, 2] + x * DP_P[0, 3])))
    b2 = x * (DP_P[2, 0] + x * (DP_P[2, 1] + x * (DP_P[2, 2] + x * DP_P[2, 3])))
    b3 = x * (DP_P[3, 0] + x * (DP_P[3, 1] + x * (DP_P[3, 2] + x * DP_P[3, 3])))
    b4 = x * (DP_P[4, 0] + x * (DP_P[4, 1] + x * (DP_P[4, 2] + x * DP_P[4, 3])))
    b5 = x * (DP_P[5, 0] + x * (DP_P[5, 1] + x * (DP_P[5, 2] + x * DP_P[5, 3])))
    b6 = x * (DP_P[6, 0] + x * (DP_P[6, 1] + x * (DP_P[6, 2] + x * DP_P[6, 3])))
    for r in range(out.shape[0]):
        out[r] = z0[r] + h * (b0 * K[0, r] + b2 * K[2, r] + b3 * K[3, r] + b4 * K[4, r] + b5 * K[5, r]
                              + b6 * K[6, r])


@kernel
def order(m):
    return ORDER


RK45.attempt = attempt
RK45.dense = dense
RK45.order = order
