"""The kinematics and task-space operations behind :mod:`service.routes.kinematics`: which library call answers
each endpoint, and how large its answer is per state.

They run through the same path as the dynamics operations (:meth:`service.compute.Compute.dynamics`: the model
from the cache, ``locked``, the batch limit, the time budget, the ``scene``); only the operations whose answer
has several parts (placements and their frame names, the centre of mass with its Jacobian, inverse kinematics'
q and report) have a ``call`` of their own here. The library checks every argument (frames, references, rows,
shapes) and its errors name the field (422).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import schemas
from .compute import Endpoint, Operation
from .errors import InvalidInput
from .library import lib

#: the inverse-kinematics options passed on to the library when given (None: its default)
IK_OPTIONS = ("position_only", "tol", "max_iter", "damping", "respect_limits")


def placements(model, args: dict[str, Any]) -> dict[str, Any]:
    """dynamics.forward_kinematics, restricted to the asked frames (all by default) in the asked order."""
    names = args.get("frames")
    index = None if names is None else [model.frame_index(name) for name in names]  # unknown: closest names listed
    T = lib().forward_kinematics(model, args["q"])
    if index is None:
        return {"placements": T, "frames": list(model.frame_names)}
    return {"placements": np.ascontiguousarray(T[..., index, :, :]), "frames": list(names)}


def center_of_mass(model, args: dict[str, Any]) -> dict[str, Any]:
    """The centre of mass and its Jacobian; its velocity too when v was given."""
    q, v = args["q"], args.get("v")
    out = {"center_of_mass": lib().center_of_mass(model, q), "com_jacobian": lib().com_jacobian(model, q)}
    if v is not None:
        out["center_of_mass_velocity"] = lib().center_of_mass_velocity(model, q, v)
    out["total_mass"] = model.total_mass
    return out


def inverse_kinematics(model, args: dict[str, Any]) -> dict[str, Any]:
    options = {k: args[k] for k in IK_OPTIONS if args.get(k) is not None}
    q, report = lib().inverse_kinematics(model, args["frame"], args["target"], args["q0"], **options)
    if not np.all(np.isfinite(report["residual"])):  # (a 200 with residual null and "stalled" said nothing)
        far = float(np.max(np.abs(np.asarray(args["target"], dtype=float))))
        raise InvalidInput(f"target: the distance to it overflows float64 (a coordinate of {far:.3g}); expected a "
                           f"target within reach of the robot (coordinates well under 1e150 m)", "target")
    return {"q": q, "report": report}


def _frames_asked(model, args: dict[str, Any]) -> int:
    return len(model.frame_names) if args.get("frames") is None else len(args["frames"])


def _rows(args: dict[str, Any]) -> int:
    return 6 if args.get("rows") is None else len(args["rows"])


#: the kinematics endpoints, by URL segment (routes in service.routes.kinematics)
OPERATIONS: dict[str, Operation] = {
    "kinematics": Operation("forward kinematics", "forward_kinematics", ("q",), ("frames",), "placements",
                            call=placements, per_state=lambda model, args: 16 * _frames_asked(model, args),
        endpoint=Endpoint(schemas.KinematicsRequest, schemas.KinematicsAnswer,
                          "world placements of the asked frames (all by default)")),
    "jacobian": Operation("frame Jacobian", "frame_jacobian", ("q",), ("frame", "reference", "point"), "jacobian",
                          per_state=lambda model, args: 6 * model.nv,
        endpoint=Endpoint(schemas.JacobianRequest, schemas.JacobianAnswer,
                          "a frame's Jacobian J (6, nv), [linear; angular]")),
    "center-of-mass": Operation("centre of mass", "center_of_mass", ("q", "v"), (), "center_of_mass",
                                call=center_of_mass, per_state=lambda model, args: 6 + 3 * model.nv,
        endpoint=Endpoint(schemas.CenterOfMassRequest, schemas.CenterOfMassAnswer,
                          "centre of mass, its Jacobian and (given v) its velocity")),
    "inverse-mass-matrix": Operation("inverse mass matrix", "inverse_mass_matrix", ("q",), (), "inverse_mass_matrix",
                                     per_state=lambda model, args: model.nv * model.nv,
        endpoint=Endpoint(schemas.InverseMassMatrixRequest, schemas.InverseMassMatrixAnswer,
                          "M(q)^-1, directly in O(n^2)")),
    "operational-space-inertia": Operation("operational space inertia", "operational_space_inertia", ("q",),
                                           ("frame", "reference", "rows", "damping"), "operational_space_inertia",
                                           per_state=lambda model, args: _rows(args) ** 2,
        endpoint=Endpoint(schemas.OperationalSpaceInertiaRequest, schemas.OperationalSpaceInertiaAnswer,
                          "Lambda = (J M^-1 J^T)^-1 for a frame's Jacobian rows")),
    "inverse-kinematics": Operation("inverse kinematics", "inverse_kinematics", ("q0",), ("frame",) + IK_OPTIONS,
                                    "q", call=inverse_kinematics, batched=(("target", 2),), iterative=True,
        endpoint=Endpoint(schemas.InverseKinematicsRequest, schemas.InverseKinematicsAnswer,
                          "q placing a frame at a target pose or position (damped least squares), and the report")),
}
