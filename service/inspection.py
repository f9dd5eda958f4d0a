"""What the inspector page draws of a robot, beyond its description (``GET /v1/robots/{id}/inspect``).

The model's neutral configuration (:meth:`dynamics.Model.neutral`: identity quaternions, a planar joint's
(cos, sin) = (1, 0), 1-dof joints within their limits), where the page's pose tab starts: the page reads it here
rather than rebuilding the library's rule. Per body: its joint (type, axis in the joint frame, placement in the
parent body at q = 0) and the check of its mass properties (:func:`dynamics.check_inertias`: principal moments
and axes, positive definiteness, the triangle inequality, the inertia box a viewer draws when the body has no
collision geometry); the model's collision geometry (``model.collision_geometry``,
:func:`service.models.collision_geometry`). Numbers come from the library; this module only lays them out as
JSON. Called from a compute thread (the model may have to be built).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .codec import finite_or_none
from .library import lib


def _body(model, i: int, check) -> dict[str, Any]:
    parent = int(model.parents[i])
    return {
        "name": model.body_names[i], "parent": parent, "joint": model.joint_names[i],
        "joint_type": model.joint_types[i], "axis": [float(x) for x in model.axes[i]],
        "placement": model.placements[i].tolist(),
        "mass": check.mass, "com": check.com.tolist(), "inertia": check.inertia.tolist(),
        "principal_moments": check.principal_moments.tolist(), "principal_axes": check.principal_axes.tolist(),
        "positive_definite": check.positive_definite, "triangle": check.triangle,
        "relative_violation": check.relative_violation, "verdict": check.verdict, "box": check.box.tolist(),
    }


def _geometry(model, g) -> dict[str, Any]:
    """A collision geometry record as JSON: its body by name (None for the world), as GET /v1/robots/{id} has it."""
    return {"name": str(g.name), "body": model.body_names[g.body] if g.body >= 0 else None, "frame": str(g.frame),
            "kind": str(g.kind),
            "size": [finite_or_none(x) for x in np.asarray(g.size, float)], "pose": np.asarray(g.pose, float).tolist()}


def inspection(model, geometry: tuple = ()) -> dict[str, Any]:
    """The model's neutral configuration, the per-body layout of the page and ``geometry``, the model's collision
    primitives (records of ``dynamics.CollisionGeometry``: name, body, frame, kind, size, pose)."""
    checks = lib().check_inertias(model)
    return {"neutral": model.neutral().tolist(),
            "bodies_inspected": [_body(model, i, c) for i, c in enumerate(checks)],
            "collision_geometry": [_geometry(model, g) for g in geometry]}
