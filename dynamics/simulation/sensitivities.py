"""Forward sensitivities of a simulation: S(t) = dx(t)/d(x0, p), integrated with the state under the same error
control (``simulate(..., sensitivities=...)``).

With x = (q, v) and the robot's ODE x' = f(t, x, p) (:mod:`.problem`), S obeys the variational equations

    S' = df/dx(t, x(t)) S + df/dp(t, x(t)),      S(0) = [I_2nv | 0]  (columns: x0, then the parameters p)

(Hairer, Norsett & Wanner I, sec. I.14).  They are appended to the state, z = [delta, v, S (column by column),
W_source, W_passive], and the whole is stepped by the chosen method: the explicit methods (rk4, rk45, dop853)
then integrate S with the very stages of the state (the "simultaneous" approach of CVODES), and every
component of S enters the error norm with the same rtol and atol, so steps are accepted only when S is as
accurate as asked.  Radau's Newton matrix for the augmented system is block diagonal, I - h gamma diag(J, J, ...,
J) (the Jacobian of the state repeated on each column of S: the simultaneous-corrector approximation of
CVODES, Hindmarsh et al. 2005 sec. 3.2): its LU, solves and spectral radius cost about as much as one of
J's per column, because radau's linear algebra visits only each row's envelope (:mod:`.solvers.linalg`).

df/dx is :func:`.jacobian.robot_jacobian` (the ABA's derivatives, the source's and passive torques'), or finite
differences of the right-hand side for a constrained model.  df/dp is the right-hand side differenced with
respect to the parameter (central differences of a function affine in each supported parameter: exact but for
rounding, ~1e-10 relative).

Coordinates (Pinocchio's convention, the tangent space): for a configuration q(t) and a perturbed run's
q~(t), the tangent displacement is dq(t) = difference(q(t), q~(t)) (nv components; q~ = q (+) dq, Pinocchio's
``integrate``), and S's q-rows are dq(t) differentiated with respect to the columns; the x0-columns q0[i] are the
tangent components of dq0 with q0~ = integrate(q0, dq0) (for a free joint: the body-frame linear and angular
displacement).  For 1-dof joints dq is plain q~ - q.

Inside the run the q-rows are chart rows: d delta(t) (the chart of :mod:`dynamics.configuration` around the
step's base).  With C(q, delta) = d delta / d e for the tangent displacement e at q = retract(base, delta)
(exactly the chart rate's matrix: delta' = C(q, delta) v, column k the rate of v = e_k), the conversions are
exact linear maps:

    S0 = C(q0, 0) on the q0-columns' q-rows;   S_tangent = C(q, delta)^-1 S_chart at each sample;
    S <- C(q1, 0) C(q1, delta1)^-1 S at a re-centring (base <- q1 = retract(base, delta1), delta <- 0)

(the chain rule through the tangent at q1; positions and 1-dof coordinates are unchanged, rotations get the
SO(3) right Jacobian Jr(delta_theta)).  After a re-centring dS/dt is evaluated again in the new chart (its
derivative depends on the chart, so the first-same-as-last stage is not reused for S): one right-hand side and
Jacobian more per accepted step, for models with a free, spherical or planar joint only.

With contact (:class:`dynamics.Contact`) df/dx holds the contact force's derivatives (central differences of
the contact law, :func:`.jacobian.robot_jacobian`, after an evaluation that touched something).  The compliant force k x (1 + d xdot)_+ is continuous at
touch-down (x = 0), so the flow is differentiable and no jump of S occurs there (the saltation matrix
I + (f+ - f-) n^T / (n^T f-) is the identity when f+ = f-); df/dx is only piecewise smooth (it jumps at x = 0
and where the clamp acts), so S's error is controlled by the step size there and S at an exact touch-down time
is the one-sided limit's mix.  Measured on a ball through an impact: S agrees with differences of whole runs
to ~1e-5 relative after the impact (1e-13 in flight), a systematic limit not yet explained.

The parameters are entries of the compiled torque source
(:class:`dynamics.control.sources.Source`): PD's kp, kd, v_target, tau_ff (rows of ``gains``) and q_target
(``qref``), a computed torque's kp and kd, a constant torque, a table's torques.
"""

from typing import NamedTuple

import numpy as np

from .._numba import generic_kernel, kernel
from ..control.sources import COMPUTED_TORQUE, CONSTANT, PD_KIND, TABLE_LINEAR, TABLE_ZOH
from ..configuration import chart_rate_in
from ..errors import InputError
from .solvers.interface import new_stats, problem_emit, problem_rebase, problem_rhs, problem_touchdown
from .solvers.linalg import lu_factor, lu_solve, problem_jacobian

GAINS, QREF, TABLE = 0, 1, 2  # where a parameter lives in the Source
FD_STEP = 6e-6
#: radau and auto: the largest augmented state (their dense Newton matrices: ~64 n^2 bytes, 256 MB here)
MAX_IMPLICIT_STATE = 2000


class SensitivityProblem(NamedTuple):
    """A robot problem (``inner``) with the variational equations appended (module docstring)."""

    inner: object  # the RobotProblem or ConstrainedProblem
    nx: int  # columns of S with respect to x0: 2 nv, or 0 when only parameters were asked
    params: np.ndarray  # (P, 3) int64: (GAINS | QREF | TABLE, row, column) of each parameter in inner.source
    zi: np.ndarray  # (2 nv + 2,) the inner problem's state
    fi: np.ndarray  # (2 nv + 2,) its right-hand side
    fp: np.ndarray  # (2 nv + 2,) scratch of the parameter differences
    fm: np.ndarray
    magi: np.ndarray  # (2 nv + 2,) the inner magnitudes
    J: np.ndarray  # (2 nv + 2, 2 nv + 2) the inner Jacobian
    B: np.ndarray  # (2 nv, P) df/dp
    jst: np.ndarray  # (1,) STATS: the Jacobian evaluations of the variational equations (not the run's)
    out_S: np.ndarray  # (T, 2 nv, ncol) or (0, 2 nv, ncol): S per sample (tangent q-rows)
    Sf: np.ndarray  # (2 nv, ncol): S at the last re-centring, tangent q-rows (models with nq != nv)
    C: np.ndarray  # (nv, nv) scratch: the chart matrix C(q, delta) (module docstring), then its LU
    piv: np.ndarray  # (nv,) int64 scratch
    col: np.ndarray  # (nv,) scratch
    delta: np.ndarray  # (nv,) scratch: the chart coordinates before a re-centring

    # what the run entry points and the progress bar read of a problem, from Python
    tag = property(lambda self: self.inner.tag)
    chart = property(lambda self: self.inner.chart)
    ws_source = property(lambda self: self.inner.ws_source)
    contact = property(lambda self: self.inner.contact)
    out_t = property(lambda self: self.inner.out_t)
    count = property(lambda self: self.inner.count)


def sensitivity_problem(inner, x0, params, out_t, keep):
    """Wrap ``inner``: S with respect to x0 (bool) and to ``params`` ((P, 3) int64), kept per sample if ``keep``."""
    nv = inner.tau_s.shape[0]
    n = 2 * nv + inner.out_w.shape[1]  # the state and its quadratures (two, three with contact)
    ncol = (2 * nv if x0 else 0) + params.shape[0]
    Sf = np.zeros((2 * nv, ncol))
    Sf[:, :2 * nv if x0 else 0] = np.eye(2 * nv)[:, :2 * nv if x0 else 0]
    return SensitivityProblem(inner, 2 * nv if x0 else 0, params, np.zeros(n), np.zeros(n), np.zeros(n),
                              np.zeros(n), np.zeros(n), np.zeros((n, n)), np.zeros((2 * nv, params.shape[0])),
                              new_stats(), np.zeros((out_t.shape[0] if keep else 0, 2 * nv, ncol)), Sf,
                              np.zeros((nv, nv)), np.zeros(nv, np.int64), np.zeros(nv), np.zeros(nv))


def initial_state(p, v0):
    """z0 = [0, v0, S0 = [C0 | 0] column by column, 0, ...]: C0 = C(q0, 0) on the q0-columns' q-rows (the identity
    for 1-dof joints, module docstring)."""
    nv = v0.shape[0]
    n2, ncol, nquad = 2 * nv, p.out_S.shape[2], p.zi.shape[0] - 2 * nv
    z = np.zeros(n2 + n2 * ncol + nquad)
    z[nv:n2] = v0
    S0 = np.zeros((n2, ncol))
    S0[:, :p.nx] = np.eye(n2)[:, :p.nx]
    if p.nx and p.inner.base.shape[0] != nv:
        C0 = np.empty((nv, nv))
        chart_matrix(p.inner.chart, p.inner.tree, p.inner.base, np.zeros(nv), C0)
        S0[:nv, :nv] = C0
    z[n2:n2 + n2 * ncol] = S0.T.ravel()
    return z


def final_sensitivities(p, z):
    """S (2 nv, ncol) at the end of a run, tangent q-rows: from the augmented state (1-dof joints), or the one
    converted at the last re-centring (after the last step)."""
    n2, ncol = p.Sf.shape
    if p.inner.base.shape[0] != n2 // 2:
        return p.Sf.copy()
    return z[n2:n2 + n2 * ncol].reshape(ncol, n2).T.copy()


@kernel
def chart_matrix(tag, tree, q, delta, C):
    """C = d delta / d e for the tangent displacement e at q = retract(base, delta) (q (+) e, Pinocchio's
    integrate): column k is the chart rate of the velocity e_k (the rate is linear in v and is this derivative,
    :mod:`dynamics.configuration`)."""
    nv = C.shape[0]
    e, col = np.zeros(nv), np.empty(nv)
    for k in range(nv):
        e[k] = 1.0
        chart_rate_in(tag, tree, q, delta, e, col)
        e[k] = 0.0
        for r in range(nv):
            C[r, k] = col[r]


@kernel
def rows_to_tangent(C, piv, col, z, o, ncol, n2, S):
    """S[:, c] = [C^-1 S_q, S_v] of the c-th column of S stored in z from offset o (C: chart_matrix's, LU-factored
    here)."""
    nv = C.shape[0]
    lu_factor(C, piv)
    for c in range(ncol):
        b = o + c * n2
        for r in range(nv):
            col[r] = z[b + r]
        lu_solve(C, piv, col)
        for r in range(nv):
            S[r, c] = col[r]
        for r in range(nv, n2):
            S[r, c] = z[b + r]


@generic_kernel
def _split(p, z):
    """The inner state of z (its first 2 nv components and the quadratures at its end)."""
    zi = p.zi
    n2 = p.B.shape[0]
    nquad = zi.shape[0] - n2
    N = z.shape[0]
    for r in range(n2):
        zi[r] = z[r]
    for r in range(nquad):
        zi[n2 + r] = z[N - nquad + r]


@generic_kernel
def _join(fi, n2, dz):
    nquad = fi.shape[0] - n2
    N = dz.shape[0]
    for r in range(n2):
        dz[r] = fi[r]
    for r in range(nquad):
        dz[N - nquad + r] = fi[n2 + r]


@generic_kernel
def _param_swap(src, code, row, col, x):
    """Set the parameter to x; returns its previous value."""
    if code == GAINS:
        old = src.gains[row, col]
        src.gains[row, col] = x
    elif code == QREF:
        old = src.qref[col]
        src.qref[col] = x
    else:
        old = src.table[row, col]
        src.table[row, col] = x
    return old


@generic_kernel
def parameter_derivatives(p, t):
    """p.B = d(q', v')/dp at (t, p.zi): the inner right-hand side differenced in each parameter (restored bit
    for bit afterwards)."""
    inner, pr = p.inner, p.params
    n2 = p.B.shape[0]
    for j in range(pr.shape[0]):
        x = _param_swap(inner.source, pr[j, 0], pr[j, 1], pr[j, 2], 0.0)
        h = FD_STEP * max(1.0, abs(x))
        _param_swap(inner.source, pr[j, 0], pr[j, 1], pr[j, 2], x + h)
        problem_rhs(inner, t, p.zi, p.fp)
        _param_swap(inner.source, pr[j, 0], pr[j, 1], pr[j, 2], x - h)
        problem_rhs(inner, t, p.zi, p.fm)
        _param_swap(inner.source, pr[j, 0], pr[j, 1], pr[j, 2], x)
        for r in range(n2):
            p.B[r, j] = (p.fp[r] - p.fm[r]) / (2 * h)


@generic_kernel
def rhs(p, t, z, dz):
    """dz = [f(t, x), J S + [0 | df/dp], powers] (module docstring)."""
    _split(p, z)
    problem_rhs(p.inner, t, p.zi, p.fi)
    n2 = p.B.shape[0]
    _join(p.fi, n2, dz)
    problem_jacobian(p.inner, t, p.zi, p.fi, p.magi, n2, p.J, p.jst[0])
    if p.params.shape[0] > 0:
        parameter_derivatives(p, t)
    ncol = p.out_S.shape[2]
    J = p.J
    for c in range(ncol):
        o = n2 + c * n2
        for r in range(n2):
            s = p.B[r, c - p.nx] if c >= p.nx else 0.0
            for k in range(n2):
                s += J[r, k] * z[o + k]
            dz[o + r] = s


@generic_kernel
def jacobian(p, t, z, f0, mag, ne, J, st):
    """Radau's Newton matrix of the augmented system: diag(Jx, Jx, ..., Jx) and the quadratures' rows, Jx the
    inner Jacobian (the simultaneous-corrector approximation, module docstring)."""
    _split(p, z)
    n2 = p.B.shape[0]
    nquad = p.zi.shape[0] - n2
    problem_jacobian(p.inner, t, p.zi, p.fi, p.magi, n2, p.J, st)
    Jx = p.J
    N = z.shape[0]
    for r in range(N):
        for k in range(N):
            J[r, k] = 0.0
    ncol = p.out_S.shape[2]
    for b in range(ncol + 1):
        o = b * n2
        for r in range(n2):
            for k in range(n2):
                J[o + r, o + k] = Jx[r, k]
    for r in range(nquad):
        for k in range(n2):
            J[N - nquad + r, k] = Jx[n2 + r, k]


@generic_kernel
def rebase(p, t, z, dz, mag):
    """The inner problem's re-centring; S's magnitudes are its own (zero here).  With 1-dof joints the chart moves
    by a shift: S is unchanged.  Otherwise S's q-rows are carried to the new chart, S <- C(q1, 0) C(q1, delta1)^-1 S,
    the tangent S kept in p.Sf, and dz evaluated again in the new chart (module docstring)."""
    _split(p, z)
    n2 = p.B.shape[0]
    nv = n2 // 2
    free = p.inner.base.shape[0] != nv
    for r in range(nv):
        p.delta[r] = p.zi[r]
    problem_rebase(p.inner, t, p.zi, p.fi, p.magi)
    for r in range(n2):
        z[r] = p.zi[r]
        mag[r] = p.magi[r]
    _join(p.fi, n2, dz)
    for r in range(n2, z.shape[0]):
        mag[r] = 0.0
    if not free:
        return
    inner, ncol = p.inner, p.Sf.shape[1]
    chart_matrix(inner.chart, inner.tree, inner.base, p.delta, p.C)  # C(q1, delta1): q1 is the new base
    rows_to_tangent(p.C, p.piv, p.col, z, n2, ncol, n2, p.Sf)
    for r in range(nv):
        p.delta[r] = 0.0
    chart_matrix(inner.chart, inner.tree, inner.base, p.delta, p.C)  # C(q1, 0)
    for c in range(ncol):
        o = n2 + c * n2
        for r in range(nv):
            s = 0.0
            for k in range(nv):
                s += p.C[r, k] * p.Sf[k, c]
            z[o + r] = s
    rhs(p, t, z, dz)


@generic_kernel
def emit(p, j, t, z):
    """Sample j of the inner problem and S with tangent q-rows (C(q, delta)^-1 on the chart rows)."""
    _split(p, z)
    problem_emit(p.inner, j, t, p.zi)
    if p.out_S.shape[0] > 0:
        inner = p.inner
        n2 = p.B.shape[0]
        nv = n2 // 2
        S = p.out_S[j]
        if inner.base.shape[0] == nv:
            for c in range(S.shape[1]):
                for r in range(n2):
                    S[r, c] = z[n2 + c * n2 + r]
            return
        q = inner.out_q[j] if inner.out_q.shape[0] > 0 else inner.qbuf  # the inner emit's q
        chart_matrix(inner.chart, inner.tree, q, z[:nv], p.C)
        rows_to_tangent(p.C, p.piv, p.col, z, n2, S.shape[1], n2, S)


@generic_kernel
def touchdown(p):
    """The inner problem's contact test (``auto``'s switch at a touch-down)."""
    return problem_touchdown(p.inner)


SensitivityProblem.rhs = rhs
SensitivityProblem.rebase = rebase
SensitivityProblem.emit = emit
SensitivityProblem.jacobian = jacobian
SensitivityProblem.touchdown = touchdown


# ---------------------------------------------------------------------------------------------------
# the Python side: what simulate's ``sensitivities`` argument asks for
#: parameter name -> (where it lives, the gains row) per torque kind; "tau" of a table is every entry
_PD_PARAMS = {"kp": (GAINS, 0), "kd": (GAINS, 1), "v_target": (GAINS, 2), "tau_ff": (GAINS, 3), "q_target": (QREF, 0)}
_CT_PARAMS = {"kp": (GAINS, 0), "kd": (GAINS, 1)}


class Spec(NamedTuple):
    """The checked ``sensitivities`` argument: S with respect to x0 (bool), the parameters ((P, 3) int64) and
    the name of every column of S."""

    x0: bool
    params: np.ndarray
    columns: tuple


def _kind_params(src):
    if src.kind == PD_KIND:
        return _PD_PARAMS
    if src.kind == COMPUTED_TORQUE:
        return _CT_PARAMS
    if src.kind == CONSTANT:
        return {"tau": (GAINS, 0)}
    if src.kind in (TABLE_LINEAR, TABLE_ZOH):
        return {"tau": (TABLE, -1)}
    return {}


def sensitivity_spec(model, src, sensitivities, integrator, project):
    """Check ``sensitivities`` (None/False: none; True: with respect to x0; or a sequence of "x0" and parameter
    names of the torque source) against the model and the source; returns a :class:`Spec` or None."""
    if sensitivities is None or sensitivities is False:
        return None
    names = ("x0",) if sensitivities is True else sensitivities
    if isinstance(names, str) or not all(isinstance(x, str) for x in np.atleast_1d(np.asarray(names, object))):
        raise InputError(f"sensitivities: expected True or a sequence of names such as ('x0', 'kp'), got "
                         f"{sensitivities!r}")
    names = tuple(names)
    allowed = _kind_params(src)
    unknown = [x for x in names if x != "x0" and x not in allowed]
    if unknown or not names or len(set(names)) != len(names):
        raise InputError(f"sensitivities: expected distinct names among {('x0',) + tuple(allowed)} for this torque "
                         f"source, got {names!r}")
    if "q_target" in names and model.nq != model.nv:
        raise InputError("sensitivities: 'q_target' is for models of 1-dof joints only (nq == nv): this model has a "
                         "free, spherical or planar joint, whose target configuration is no vector of nv entries; "
                         "ask for 'x0', 'kp', 'kd', 'v_target' or 'tau_ff'")
    if integrator == "euler":
        raise InputError("sensitivities: not with integrator='euler'; use 'rk4', 'rk45', 'dop853', 'radau' or 'auto'")
    if project:
        raise InputError("sensitivities: not with project=True (the projection is not differentiated)")
    nv = model.nv
    cols = [f"q0[{i}]" for i in range(nv)] + [f"v0[{i}]" for i in range(nv)] if "x0" in names else []
    params = []
    for name in names:
        if name == "x0":
            continue
        code, row = allowed[name]
        if code == TABLE:
            N = src.table.shape[0]
            params += [(TABLE, k, i) for k in range(N) for i in range(nv)]
            cols += [f"tau[{k},{i}]" for k in range(N) for i in range(nv)]
        else:
            params += [(code, row, i) for i in range(nv)]
            cols += [f"{name}[{i}]" for i in range(nv)]
    n = 2 * nv * (1 + len(cols))
    if integrator in ("radau", "auto") and n > MAX_IMPLICIT_STATE:
        raise InputError(f"sensitivities: {len(cols)} columns make a state of {n} components, over the "
                         f"{MAX_IMPLICIT_STATE} that {integrator!r} takes (its Newton matrix is dense, n x n); use "
                         "integrator='rk45' or 'dop853', or ask for fewer parameters")
    return Spec("x0" in names, np.array(params, np.int64).reshape(-1, 3), tuple(cols))


def error_estimate(main_S, rerun_S, factor):
    """The sensitivities' part of the report's error estimate: max |S - S_tighter| at the final time (scaled as
    the state's, :mod:`.report`)."""
    if main_S is None or rerun_S is None:
        return None
    est = float(np.max(np.abs(main_S - rerun_S), initial=0.0)) * factor
    return est if np.isfinite(est) else None  # (a failed rerun: no estimate, and strict JSON)
