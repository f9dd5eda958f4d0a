"""Derivatives of the dynamics: ``POST /v1/robots/{id}/derivatives/inverse_dynamics``, ``/forward_dynamics`` and
``/constrained_forward_dynamics``
with one state or a batch, JSON or .npz, ``locked`` and ``scene`` like the dynamics operations (same path:
:func:`service.routes.dynamics.add_routes`; the library calls are :data:`service.derivatives.OPERATIONS`)."""

from __future__ import annotations

from fastapi import APIRouter

from ..derivatives import OPERATIONS
from .dynamics import add_routes

router = APIRouter(prefix="/v1")
add_routes(router, OPERATIONS)
