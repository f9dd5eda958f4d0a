"""Forward sensitivities of a simulation: S(t) = dx(t)/d(x0, p), integrated with the state under the same error
control (``simulate(..., sensitivities=...)``).

With x = (q, v) and the robot's ODE x' = f(t, x, p) (``core/simulation/robot_problem.hpp``), S obeys the variational equations

    S' = df/dx(t, x(t)) S + df/dp(t, x(t)),      S(0) = [I_2nv | 0]  (columns: x0, then the parameters p)

(Hairer, Norsett & Wanner I, sec. I.14).  They are appended to the state, z = [delta, v, S (column by column),
W_source, W_passive], and the whole is stepped by the chosen method: the explicit methods (rk4, rk45, dop853)
then integrate S with the very stages of the state (the "simultaneous" approach of CVODES), and every
component of S enters the error norm with the same rtol and atol, so steps are accepted only when S is as
accurate as asked.  Radau's Newton matrix for the augmented system is block diagonal, I - h gamma diag(J, J, ...,
J) (the Jacobian of the state repeated on each column of S: the simultaneous-corrector approximation of
CVODES, Hindmarsh et al. 2005 sec. 3.2): its LU, solves and spectral radius cost about as much as one of
J's per column, because radau's linear algebra visits only each row's envelope (``core/simulation/linalg.hpp``).
The variational equations are the core's (``core/simulation/sensitivities.cpp``); this module checks what a call
asks for.

df/dx is the robot problem's Jacobian (``core/simulation/robot_jacobian.cpp``: the ABA's derivatives, the
source's and passive torques', the contact's), or finite
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
the contact law, after an evaluation that touched something).  The compliant force k x (1 + d xdot)_+ is continuous at
touch-down (x = 0), so the flow is differentiable and no jump of S occurs there (the saltation matrix
I + (f+ - f-) n^T / (n^T f-) is the identity when f+ = f-); df/dx is only piecewise smooth (it jumps at x = 0
and where the clamp acts), so S's error is controlled by the step size there and S at an exact touch-down time
is the one-sided limit's mix.  Measured on a ball through an impact: S agrees with differences of whole runs
to ~1e-5 relative after the impact (1e-13 in flight), a systematic limit not yet explained.

The parameters are entries of the torque source
(:class:`dynamics.control.sources.Source`): PD's kp, kd, v_target, tau_ff (rows of ``gains``) and q_target
(``qref``), a computed torque's kp and kd, a constant torque, a table's torques.
"""

from typing import NamedTuple

import numpy as np

from ..control.sources import COMPUTED_TORQUE, CONSTANT, PD_KIND, TABLE_LINEAR, TABLE_ZOH
from ..errors import InputError

#: where a parameter lives in the Source (core/simulation/sensitivities.hpp's GAINS, QREF, TABLE)
GAINS, QREF, TABLE = 0, 1, 2
#: radau and auto: the largest augmented state (their dense Newton matrices: ~64 n^2 bytes, 256 MB here)
MAX_IMPLICIT_STATE = 2000


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
    if integrator in ("euler", "implicit_euler"):
        raise InputError(f"sensitivities: not with integrator={integrator!r}; use 'rk4', 'rk45', 'dop853', 'radau' or 'auto'")
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
