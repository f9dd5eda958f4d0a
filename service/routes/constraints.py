"""Closed loops and coupled joints: ``POST /v1/robots/{id}/<operation>`` with one state or a batch, JSON or .npz,
``locked`` and ``scene`` like the dynamics operations (same path: :func:`service.routes.dynamics.add_routes`;
the library calls are :data:`service.constraints.OPERATIONS`)."""

from __future__ import annotations

from fastapi import APIRouter
from pydantic import BaseModel

from .. import schemas
from ..constraints import OPERATIONS
from .dynamics import add_routes

#: URL segment -> (request schema, answer schema, summary)
ROUTES: dict[str, tuple[type[BaseModel], type[BaseModel], str]] = {
    "constraint-residual": (schemas.ConstraintResidualRequest, schemas.ConstraintResidualAnswer,
                            "phi(q): the loops' and couplings' residual (m,)"),
    "assemble": (schemas.AssembleRequest, schemas.AssembleAnswer,
                 "q closing every loop near q_guess (Gauss-Newton); 422 when the loops cannot close"),
    "constrained-forward-dynamics": (schemas.ConstrainedForwardDynamicsRequest,
                                     schemas.ConstrainedForwardDynamicsAnswer,
                                     "accelerations a and multipliers lambda of the constrained model"),
    "constrained-inverse-dynamics": (schemas.ConstrainedInverseDynamicsRequest, schemas.TauAnswer,
                                     "torques of the actuated joints for a motion the loops allow"),
}

router = APIRouter(prefix="/v1")
add_routes(router, ROUTES, OPERATIONS)
