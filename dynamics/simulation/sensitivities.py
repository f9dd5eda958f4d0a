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
CVODES, Hindmarsh et al. 2005 sec. 3.2): its LU costs about as much as one of J's per column, because the
elimination skips the zero blocks.

df/dx is :func:`.jacobian.robot_jacobian` (the ABA's derivatives, the source's and passive torques'), or finite
differences of the right-hand side for a constrained model.  df/dp is the right-hand side differenced with
respect to the parameter (central differences of a function affine in each supported parameter: exact but for
rounding, ~1e-10 relative).

Coordinates: 1-dof joints only (nq == nv), where the chart of the state is q itself, so S's rows are dq(t) and
dv(t) (no manifold correction).  The parameters are entries of the compiled torque source
(:class:`dynamics.control.sources.Source`): PD's kp, kd, v_target, tau_ff (rows of ``gains``) and q_target
(``qref``), a computed torque's kp and kd, a constant torque, a table's torques.
"""

from typing import NamedTuple

import numpy as np

from .._numba import generic_kernel
from ..control.sources import COMPUTED_TORQUE, CONSTANT, PD_KIND, TABLE_LINEAR, TABLE_ZOH
from ..errors import InputError
from .solvers.interface import new_stats, problem_emit, problem_rebase, problem_rhs
from .solvers.linalg import problem_jacobian

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
    out_S: np.ndarray  # (T, 2 nv, ncol) or (0, 2 nv, ncol): S per sample

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
    n = 2 * nv + 2
    ncol = (2 * nv if x0 else 0) + params.shape[0]
    return SensitivityProblem(inner, 2 * nv if x0 else 0, params, np.zeros(n), np.zeros(n), np.zeros(n),
                              np.zeros(n), np.zeros(n), np.zeros((n, n)), np.zeros((2 * nv, params.shape[0])),
                              new_stats(), np.zeros((out_t.shape[0] if keep else 0, 2 * nv, ncol)))


def initial_state(nv, v0, nx, ncol):
    """z0 = [0, v0, S0 = [I | 0] column by column, 0, 0]."""
    n2 = 2 * nv
    z = np.zeros(n2 + n2 * ncol + 2)
    z[nv:n2] = v0
    for c in range(nx):
        z[n2 + c * n2 + c] = 1.0
    return z


def final_sensitivities(z, nv, ncol):
    """S (2 nv, ncol) from an augmented state."""
    n2 = 2 * nv
    return z[n2:n2 + n2 * ncol].reshape(ncol, n2).T.copy()


@generic_kernel
def _split(p, z):
    """The inner state of z (its first 2 nv components and the two quadratures)."""
    zi = p.zi
    n2 = zi.shape[0] - 2
    N = z.shape[0]
    for r in range(n2):
        zi[r] = z[r]
    zi[n2] = z[N - 2]
    zi[n2 + 1] = z[N - 1]


@generic_kernel
def _join(fi, dz):
    n2 = fi.shape[0] - 2
    N = dz.shape[0]
    for r in range(n2):
        dz[r] = fi[r]
    dz[N - 2] = fi[n2]
    dz[N - 1] = fi[n2 + 1]


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
    _join(p.fi, dz)
    n2 = p.zi.shape[0] - 2
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
    n2 = p.zi.shape[0] - 2
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
    for r in range(2):
        for k in range(n2):
            J[N - 2 + r, k] = Jx[n2 + r, k]


@generic_kernel
def rebase(p, t, z, dz, mag):
    """The inner problem's re-centring (with 1-dof joints the chart moves by a shift: S is unchanged); S's
    magnitudes are its own (zero here)."""
    _split(p, z)
    problem_rebase(p.inner, t, p.zi, p.fi, p.magi)
    n2 = p.zi.shape[0] - 2
    for r in range(n2):
        z[r] = p.zi[r]
        mag[r] = p.magi[r]
    _join(p.fi, dz)
    for r in range(n2, z.shape[0] - 2):
        mag[r] = 0.0


@generic_kernel
def emit(p, j, t, z):
    _split(p, z)
    problem_emit(p.inner, j, t, p.zi)
    if p.out_S.shape[0] > 0:
        n2 = p.zi.shape[0] - 2
        S = p.out_S[j]
        for c in range(S.shape[1]):
            for r in range(n2):
                S[r, c] = z[n2 + c * n2 + r]


SensitivityProblem.rhs = rhs
SensitivityProblem.rebase = rebase
SensitivityProblem.emit = emit
SensitivityProblem.jacobian = jacobian


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
    if model.nq != model.nv:
        raise InputError("sensitivities: supported for models of 1-dof joints only (nq == nv); this model has a "
                         "free joint")
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
