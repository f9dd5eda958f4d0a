"""Kinematics and task space: ``POST /v1/robots/{id}/<operation>`` with one state or a batch, JSON or .npz,
``locked`` and ``scene`` like the dynamics operations (same path: :func:`service.routes.dynamics.add_routes`;
the library calls are :data:`service.kinematics.OPERATIONS`)."""

from __future__ import annotations

from fastapi import APIRouter
from pydantic import BaseModel

from .. import schemas
from ..kinematics import OPERATIONS
from .dynamics import add_routes

#: URL segment -> (request schema, answer schema, summary)
ROUTES: dict[str, tuple[type[BaseModel], type[BaseModel], str]] = {
    "kinematics": (schemas.KinematicsRequest, schemas.KinematicsAnswer,
                   "world placements of the asked frames (all by default)"),
    "jacobian": (schemas.JacobianRequest, schemas.JacobianAnswer, "a frame's Jacobian J (6, nv), [linear; angular]"),
    "center-of-mass": (schemas.CenterOfMassRequest, schemas.CenterOfMassAnswer,
                       "centre of mass, its Jacobian and (given v) its velocity"),
    "inverse-mass-matrix": (schemas.InverseMassMatrixRequest, schemas.InverseMassMatrixAnswer,
                            "M(q)^-1, directly in O(n^2)"),
    "operational-space-inertia": (schemas.OperationalSpaceInertiaRequest, schemas.OperationalSpaceInertiaAnswer,
                                  "Lambda = (J M^-1 J^T)^-1 for a frame's Jacobian rows"),
    "inverse-kinematics": (schemas.InverseKinematicsRequest, schemas.InverseKinematicsAnswer,
                           "q placing a frame at a target pose or position (damped least squares), and the report"),
}

router = APIRouter(prefix="/v1")
add_routes(router, ROUTES, OPERATIONS)
