"""A constrained robot (closed loops, coupled joints) as an ODE for the solvers.

Same state and functions as :mod:`.problem`, with the ABA of the right-hand side replaced by the KKT solve of
:mod:`dynamics.constrained_dynamics` (the lectures' formula with Baumgarte's stabilisation):

    M a + C v + g = tau + Phi_q^T lambda,    Phi_q a + Phi_q_dot v = -(2 alpha Phi_q v + beta^2 phi)

After every accepted step ``rebase`` optionally projects the state onto the constraint manifold (positions by
Gauss-Newton, velocities in the kinetic-energy metric; :func:`dynamics.constrained_dynamics._project_position_kernel`)
and re-evaluates f there, so the next step starts on the manifold.  It also tracks the largest position and
velocity residuals (max |phi|, max |Phi_q v|) at every accepted step (after projection) and at every sample:
``constraint_drift`` of the report.

Runs without contact take the C++ core's ConstrainedProblem instead (``core/simulation/constrained_problem.hpp``:
the same right-hand side, projection, drift and multipliers; :mod:`.native`); this numba problem serves runs with
contact until those move to the core too.

This module is imported by :func:`dynamics.simulate` only when the model has constraints, and its kernels
compile (with the solvers' specialisation for :class:`ConstrainedProblem`) only then: an unconstrained run
neither pays for nor sees it.
"""

from typing import NamedTuple

import numpy as np

from .._numba import copy_into, generic_kernel
from ..constrained_dynamics import (_constrained_accel_kernel, _drift_kernel, _project_position_kernel,
                           _project_velocity_kernel)
from ..constrained_dynamics import _workspace as constrained_workspace
from ..configuration import retract_in
from ..constraints import arrays
from ..contact.calls import contact_rebased
from .problem import (RobotProblem, applied_torques, chart_and_velocity, emit, euler_config, quadratures, rebase,
                      robot_problem, touchdown)

#: Gauss-Newton of the position projection: stop below this max |phi| (m or rad), after at most PROJECT_ITER steps
PROJECT_TOL = 1e-12
PROJECT_ITER = 8

ConstrainedProblem = NamedTuple("ConstrainedProblem", list(RobotProblem.__annotations__.items()) + [
    ("C", object),  # constraints.ConstraintArrays
    ("alpha", float),  # Baumgarte gains (1/s)
    ("beta", float),
    ("project", bool),  # project onto the manifold after accepted steps
    ("ws_con", tuple),  # constrained._workspace(nb, nv, m)
    ("lam", np.ndarray),  # (m,) scratch: multipliers of the last rhs evaluation
    ("abuf", np.ndarray),  # (nv,) scratch: accelerations at a sample
    ("vbuf", np.ndarray),  # (nv,) scratch: projected velocity
    ("out_lam", np.ndarray),  # (T, m) or (0, m): multipliers per sample
    ("drift", np.ndarray),  # (2,) largest max|phi| and max|Phi_q v| seen (accepted steps and samples)
    ("project_failures", np.ndarray),  # (1,) int64: position projections that did not reach PROJECT_TOL
])
ConstrainedProblem.__doc__ = """RobotProblem's fields (read by name by the reused functions) and the constraints'."""


def constrained_problem(model, passive, source, q0, out_t, outputs, alpha, beta, project, contact=None):
    """A :class:`ConstrainedProblem`: :func:`.problem.robot_problem` plus the constraints, Baumgarte gains
    alpha, beta (1/s), ``project`` and, when "lambda" is in ``outputs``, the multipliers per sample."""
    C, m = arrays(model)
    nv, nb = model.nv, model.tree.parents.shape[0]
    T = out_t.shape[0]
    return ConstrainedProblem(
        *robot_problem(model, passive, source, q0, out_t, outputs, contact), C, float(alpha), float(beta), bool(project),
        constrained_workspace(nb, nv, m), np.zeros(m), np.empty(nv), np.empty(nv),
        np.zeros((T if "lambda" in outputs else 0, m)), np.zeros(2), np.zeros(1, np.int64))


@generic_kernel
def constrained_rhs(p, t, z, dz):
    """dz = f(t, z) with the constrained accelerations (NaN when M is singular); p.lam = the multipliers."""
    nv = p.tau_s.shape[0]
    q, v = chart_and_velocity(p.chart, p.tree, p.base, p.qbuf, nv, z, dz)
    power_s, power_p, power_c = applied_torques(p.tag, p.source, p.tree, p.passive, p.ws_source, p.contact, p.tau_s,
                                                p.tau_p, t, q, v, z[:nv])
    if _constrained_accel_kernel(p.tree, p.C, p.passive.gravity, q, v, p.tau_p, p.alpha, p.beta, p.ws_con,
                                dz[nv:2 * nv], p.lam) >= 0:
        dz[nv:2 * nv] = np.nan
    quadratures(dz, nv, power_s, power_p, power_c)


@generic_kernel
def _track_drift(p, q, v):
    pos, vel = _drift_kernel(p.tree, p.C, q, v, p.ws_con)
    p.drift[0] = max(p.drift[0], pos)
    p.drift[1] = max(p.drift[1], vel)


@generic_kernel
def constrained_rebase(p, t, z, dz, mag):
    """:func:`.problem.rebase`, then (``p.project``) the projection onto phi = 0, Phi_q v = 0 and f(t, z) again
    at the projected state; then the drift of the state the next step starts from."""
    nv = p.tau_s.shape[0]
    rebase(p, t, z, dz, mag)
    v = z[nv:2 * nv]
    if p.project:
        err = _project_position_kernel(p.tree, p.C, p.base, p.ws_con, PROJECT_TOL, PROJECT_ITER, p.qbuf)
        if err <= PROJECT_TOL:
            copy_into(p.base, p.qbuf)
            contact_rebased(p.contact)  # (the clearance's bound follows chart steps, not projections)
        else:  # keep the step's configuration; the drift and the report say how far off it is
            p.project_failures[0] += 1
        if _project_velocity_kernel(p.tree, p.C, p.base, v, p.ws_con, p.vbuf) < 0:
            copy_into(v, p.vbuf)
        constrained_rhs(p, t, z, dz)
        rebase(p, t, z, dz, mag)  # the magnitudes of the projected state (z's chart part is zero)
    _track_drift(p, p.base, v)


@generic_kernel
def constrained_emit(p, j, t, z):
    """:func:`.problem.emit`, the drift at the sample and, when kept, its multipliers (those the simulation
    applies there: Baumgarte terms included)."""
    nv = p.tau_s.shape[0]
    emit(p, j, t, z)
    q = p.qbuf
    retract_in(p.chart, p.tree, p.base, z[:nv], q)  # the sample's configuration (emit kept it in out_q or qbuf)
    v = z[nv:2 * nv]
    _track_drift(p, q, v)
    if p.out_lam.shape[0] > 0:
        applied_torques(p.tag, p.source, p.tree, p.passive, p.ws_source, p.contact, p.tau_s, p.tau_p, t, q, v,
                        z[:nv])
        _constrained_accel_kernel(p.tree, p.C, p.passive.gravity, q, v, p.tau_p, p.alpha, p.beta, p.ws_con, p.abuf,
                                 p.out_lam[j])


ConstrainedProblem.rhs = constrained_rhs
ConstrainedProblem.rebase = constrained_rebase
ConstrainedProblem.euler_config = euler_config
ConstrainedProblem.emit = constrained_emit
ConstrainedProblem.touchdown = touchdown
