"""The adaptive driver: step-size bookkeeping, output sampling from dense output, chart re-centring.

The method (rk45, dop853, radau or auto, see :mod:`.interface`) decides whether an attempted step is
accepted and proposes the next step size; the driver does what every method shares: the first step
(Hairer's heuristic), the step budget, the smallest representable step, landing on t_end exactly, the
state checks, the samples in each accepted step, and the re-centring of the chart after it.
"""

import numpy as np

from ..._numba import borrow, copy_into, generic_inline, keep_alive
from .interface import (MAX_STEPS, OK, STEP_TOO_SMALL, SWITCHED, driver_rhs, problem_emit, problem_rebase, stepper_attempt,
                        stepper_dense, stepper_order)
from .linalg import initial_step, max_abs, state_status


@generic_inline
def solve_adaptive(p, m, z, t0, t_end, out_t, opt, stats, switches):
    """Integrate z from t0 to t_end with error control by the method m; returns the status (also in stats).
    Its vectors and the stepper's are borrowed (no reference counts in the step loop; :func:`.fixed.solve_fixed`)."""
    st = stats[0]
    st.switch_request = 0
    n = z.shape[0]
    owner, m_owner = np.zeros(7 * n), m  # the vectors below and the stepper's are borrowed from these
    m, z, out_t, buf = borrow(m), borrow(z), borrow(out_t), borrow(owner)
    mag = buf[:n]
    f0 = buf[n:2 * n]  # f(t, z) in the current chart
    fnew = buf[2 * n:3 * n]
    znew = buf[3 * n:4 * n]
    zold = buf[4 * n:5 * n]
    errv = buf[5 * n:6 * n]
    zi = buf[6 * n:]
    problem_rebase(p, t0, z, f0, mag)  # magnitudes of the initial state (z's chart part is zero)
    driver_rhs(p, t0, z, f0)
    st.rhs_evals += 1
    status = state_status(f0, 0, 0, opt.blowup)
    t = t0
    # the initial state, also when f(t0, z0) is not finite (a resumed run: its samples so far are written, and
    # the next one is later than t0)
    j = _emit(p, m, st.samples, out_t, t, 0.0, zold, z, zi, st)
    h = opt.h0
    if h <= 0:
        h = initial_step(p, t, z, f0, stepper_order(m), opt.rtol, opt.atol, mag, opt.ne, t_end, st)
    h = min(h, opt.hmax)
    local_err = st.local_error  # a resumed run adds to the first part's sums
    total = st.steps + st.rejected
    rejected_last = False
    while status == OK and t < t_end:
        if total >= opt.max_steps:
            status = MAX_STEPS
            break
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h < min_step:
            status = STEP_TOO_SMALL
            break
        h = min(h, opt.hmax)
        tn = t + h
        if tn >= t_end or t_end - tn < min_step:
            tn = t_end
        h = tn - t
        total += 1
        accepted, hnew = stepper_attempt(m, p, t, h, z, f0, znew, fnew, errv, mag, opt, st, switches,
                                         rejected_last)
        rejected_last = not accepted
        if not accepted:
            st.rejected += 1
            h = hnew
            continue
        st.steps += 1
        local_err += max_abs(errv, opt.ne)
        copy_into(zold, z)
        copy_into(z, znew)
        copy_into(f0, fnew)
        t = tn
        status = state_status(z, opt.nc, opt.nvel, opt.blowup)
        if status != OK:
            break
        j = _emit(p, m, j, out_t, t, h, zold, z, zi, st)
        problem_rebase(p, t, z, f0, mag)  # re-centre the chart; f0 = f(t, z) in the new chart
        h = hnew
        if st.switch_request:  # auto changes method here: the caller resumes from (t, z) with h
            status = SWITCHED
            break
    st.status = status
    st.samples = j
    st.t = t
    st.local_error = local_err
    st.h = h
    keep_alive(owner)
    keep_alive(m_owner)
    return status


@generic_inline
def _emit(p, m, j, out_t, t, h, zold, z, zi, st):
    """Emit the samples in (t - h, t] from the dense output of the step zold -> z (h = 0: the state at t)."""
    while j < out_t.shape[0] and out_t[j] <= t:
        if out_t[j] >= t or h == 0.0:
            problem_emit(p, j, t, z)
        else:
            stepper_dense(m, p, t - h, h, (out_t[j] - (t - h)) / h, zold, z, zi, st)
            problem_emit(p, j, out_t[j], zi)
        j += 1
    return j
