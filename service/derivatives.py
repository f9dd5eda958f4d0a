"""The derivative operations behind :mod:`service.routes.derivatives`: ``POST /v1/robots/{id}/derivatives/
inverse_dynamics``, ``/forward_dynamics`` and ``/constrained_forward_dynamics``, one state or a batch, through the same path as the dynamics
operations (:meth:`service.compute.Compute.dynamics`: the model from the cache, ``locked``, the batch limit, the
answer-size limit counted on the three (nv, nv) matrices per state, the time budget, the ``scene``).  The
library checks every argument and its errors name the field (422)."""

from __future__ import annotations

from typing import Any

import numpy as np

from . import schemas
from .compute import Endpoint, Operation
from .library import lib


def _keywords(args: dict[str, Any]) -> dict[str, Any]:
    return {k: args[k] for k in ("gravity", "f_ext") if args.get(k) is not None}


def inverse_dynamics(model, args: dict[str, Any]) -> dict[str, Any]:
    dq, dv, M = lib().inverse_dynamics_derivatives(model, args["q"], args["v"], args["a"], **_keywords(args))
    return {"dtau_dq": dq, "dtau_dv": dv, "mass_matrix": M}


def forward_dynamics(model, args: dict[str, Any]) -> dict[str, Any]:
    dq, dv, Minv = lib().forward_dynamics_derivatives(model, args["q"], args["v"], args["tau"], **_keywords(args))
    return {"da_dq": dq, "da_dv": dv, "inverse_mass_matrix": Minv}


CONSTRAINED_KEYS = ("da_dq", "da_dv", "da_dtau", "dlambda_dq", "dlambda_dv", "dlambda_dtau")


def constrained_forward_dynamics(model, args: dict[str, Any]) -> dict[str, Any]:
    """The six blocks of ``dynamics.constrained_forward_dynamics_derivatives``.  A robot without constraints
    gets the unconstrained ones (the ABA's derivatives, M^-1 and no multiplier rows), which is what the
    constrained dynamics are then, rather than a refusal: one route for a fleet of robots with and without loops."""
    q, v, tau = args["q"], args["v"], args["tau"]
    gravity = args.get("gravity")
    if not model.constraints:
        dq, dv, Minv = lib().forward_dynamics_derivatives(model, q, v, tau, gravity=gravity)
        none = np.zeros(dq.shape[:-2] + (0, model.nv))
        return dict(zip(CONSTRAINED_KEYS, (dq, dv, Minv, none, none, none)))
    kwargs = {k: args[k] for k in ("baumgarte", "gravity") if args.get(k) is not None}
    return dict(zip(CONSTRAINED_KEYS, lib().constrained_forward_dynamics_derivatives(model, q, v, tau, **kwargs)))


def _three_matrices(model, args: dict[str, Any]) -> int:
    return 3 * model.nv * model.nv


def _six_blocks(model, args: dict[str, Any]) -> int:
    return 3 * model.nv * (model.nv + sum(c.rows for c in model.constraints))


#: the derivative endpoints, by URL segment (routes in service.routes.derivatives)
OPERATIONS: dict[str, Operation] = {
    "derivatives/inverse_dynamics": Operation(
        "inverse dynamics derivatives", "inverse_dynamics_derivatives", ("q", "v", "a"), ("gravity", "f_ext"),
        "dtau_dq", {"v": "state", "a": "state"}, call=inverse_dynamics, per_state=_three_matrices,
        endpoint=Endpoint(schemas.InverseDynamicsRequest, schemas.InverseDynamicsDerivativesAnswer,
                          "dtau/dq (tangent space), dtau/dv and M: the analytical RNEA derivatives")),
    "derivatives/forward_dynamics": Operation(
        "forward dynamics derivatives", "forward_dynamics_derivatives", ("q", "v", "tau"), ("gravity", "f_ext"),
        "da_dq", {"v": "state", "a": "computed"}, call=forward_dynamics, per_state=_three_matrices,
        endpoint=Endpoint(schemas.ForwardDynamicsRequest, schemas.ForwardDynamicsDerivativesAnswer,
                          "da/dq (tangent space), da/dv and M^-1 = da/dtau: the analytical ABA derivatives")),
    "derivatives/constrained_forward_dynamics": Operation(
        "constrained forward dynamics derivatives", "constrained_forward_dynamics_derivatives", ("q", "v", "tau"),
        ("baumgarte", "gravity"), "da_dq", {"v": "state", "a": "computed"}, call=constrained_forward_dynamics,
        per_state=_six_blocks,
        endpoint=Endpoint(schemas.ConstrainedForwardDynamicsRequest,
                          schemas.ConstrainedForwardDynamicsDerivativesAnswer,
                          "da/dq (tangent space), da/dv, da/dtau and the multipliers' dlambda/dq, dv, dtau of the "
                          "loops and couplings (analytical; a robot without constraints: the ABA's)")),
}
