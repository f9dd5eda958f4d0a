"""The fixed-step driver (``euler``, ``rk4``): steps of size dt from t0 to t_end, the last one shortened to
land on t_end exactly, samples from the stepper's interpolant.

The slope at the end of a step serves the interpolant of that step and, re-expressed in the new chart by
``rebase``, the first stage of the next one.
"""

import numpy as np

from ..._numba import borrow, copy_into, generic_inline, keep_alive
from .interface import NONFINITE, OK, driver_rhs, problem_emit, problem_rebase, stepper_fixed_dense, stepper_step
from .linalg import jacobian_spectral_radius, state_status


@generic_inline
def solve_fixed(p, m, z, t0, t_end, out_t, opt, stats):
    """Integrate z from t0 to t_end with the fixed-step method m; returns the status (also in stats).  Its
    vectors and the stepper's are borrowed (:func:`dynamics._numba.borrow`: no reference counts in
    the step loop), their owners kept alive to the end."""
    st = stats[0]
    n = z.shape[0]
    owner, m_owner = np.zeros(5 * n), m  # the vectors below and the stepper's are borrowed from these
    m, z, out_t, buf = borrow(m), borrow(z), borrow(out_t), borrow(owner)
    mag = buf[:n]
    f0 = buf[n:2 * n]  # slope at the start of the step
    f1 = buf[2 * n:3 * n]  # slope at its end
    z0 = buf[3 * n:4 * n]
    zi = buf[4 * n:]
    driver_rhs(p, t0, z, f0)
    st.rhs_evals += 1
    status = OK if state_status(f0, 0, 0, opt.blowup) == OK else NONFINITE
    if opt.probe and status == OK:
        st.rho0 = jacobian_spectral_radius(p, t0, z, f0, opt.ne)
    j = 0
    while j < out_t.shape[0] and out_t[j] <= t0:  # the initial state, also when f(t0, z0) is not finite
        problem_emit(p, j, t0, z)
        j += 1
    t = t0
    for i in range(opt.nsteps if status == OK else 0):
        ta = t  # this step: from ta to t
        t = t_end if i == opt.nsteps - 1 else min(t0 + (i + 1) * opt.dt, t_end)
        h = t - ta
        copy_into(z0, z)
        stepper_step(m, p, ta, h, z, f0, st)
        st.steps += 1
        status = state_status(z, opt.nc, opt.nvel, opt.blowup)
        if status != OK:
            break
        driver_rhs(p, t, z, f1)
        st.rhs_evals += 1
        if state_status(f1, 0, 0, opt.blowup) != OK:
            status = NONFINITE
            break
        while j < out_t.shape[0] and out_t[j] <= t:  # samples in (ta, t]
            if out_t[j] >= t:
                problem_emit(p, j, t, z)
            else:
                stepper_fixed_dense(m, (out_t[j] - ta) / h, h, z0, f0, z, f1, zi)
                problem_emit(p, j, out_t[j], zi)
            j += 1
        problem_rebase(p, t, z, f1, mag)
        copy_into(f0, f1)
    st.status = status
    st.t = t
    st.h = opt.dt
    st.local_error = np.nan  # fixed-step methods have no embedded error estimate
    keep_alive(owner)
    keep_alive(m_owner)
    return status

