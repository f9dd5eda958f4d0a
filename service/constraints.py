"""Closed loops and coupled joints in the service (issue 10): the constraints of an upload, a model's constraints
in robot info, and the operations behind :mod:`service.routes.constraints`.

Constraints given as JSON on upload are written into the stored URDF as the library's own elements (a
``<loop>`` per closure, a ``<mimic>`` per coupling; ``mimic="independent"`` removes the ``<mimic>`` elements),
so that the document is the one source of the model: its id derives from it (the same URDF with other
constraints is another robot), and every process that builds the model from it (the server's threads, the
simulation workers, a reduced ``locked`` model) gets the same constraints without a second place to keep them.
Frames that are not URDF links (joint frames) become an anchor on the link of their body at the frame's pose.
The library checks every declaration (unknown frames and joints with the closest names, over-constrained sets
with their rank); an upload whose loops do not close near the neutral configuration is refused.

The endpoints run through the same path as the dynamics operations (:meth:`service.compute.Compute.dynamics`);
only constrained forward dynamics (a and lambda) has a ``call`` of its own.
"""

from __future__ import annotations

from typing import Any, Optional

import numpy as np
from lxml import etree

from . import schemas
from .compute import Endpoint, Operation
from .errors import InvalidInput
from .library import lib
from .models import load_model

_PARSER = dict(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False, remove_blank_text=False)
_KINDS = {"PointConstraint": "point", "WeldConstraint": "weld", "RevoluteConstraint": "revolute",
          "JointCoupling": "coupling"}


# -- upload: JSON declarations -> the URDF's own elements ---------------------------------------------------------
def declarations(specs: list[Any]) -> list[Any]:
    """The request's constraint specs (service.schemas.ConstraintSpec) -> the library's declarations; the
    library's checks (a zero axis, a bad placement) are 422s naming ``constraints[k]``."""
    out = []
    for k, s in enumerate(specs):
        name = s.name or f"constraint{k}"
        try:
            if s.type == "coupling":
                out.append(lib().JointCoupling(s.follower, s.leader, s.multiplier, s.offset, name=name))
            elif s.type == "point":
                out.append(lib().PointConstraint(s.frame_a, s.frame_b, _vec(s.point_a), _vec(s.point_b), name=name))
            elif s.type == "weld":
                out.append(lib().WeldConstraint(s.frame_a, s.frame_b, s.placement, name=name))
            else:
                out.append(lib().RevoluteConstraint(s.frame_a, s.frame_b, s.axis, _vec(s.point_a), _vec(s.point_b),
                                                    None if s.axis_b is None else s.axis_b, name=name))
        except ValueError as e:
            raise InvalidInput(f"constraints[{k}]: {e}", f"constraints[{k}]") from None
    return out


def _vec(x: Any) -> tuple:
    return (0.0, 0.0, 0.0) if x is None else x


def declare(urdf: bytes, floating_base: bool, specs: Optional[list[Any]], mimic: Optional[str]) -> bytes:
    """The document to store: ``urdf`` with ``specs`` written as ``<loop>``/``<mimic>`` elements and, for
    ``mimic="independent"``, without its ``<mimic>`` elements. Unchanged (the same bytes) when there is
    nothing to add."""
    if not specs and mimic != "independent":
        return urdf
    root = etree.fromstring(urdf, etree.XMLParser(**_PARSER))
    if mimic == "independent":
        for el in root.findall("joint/mimic"):
            el.getparent().remove(el)
    if specs:
        cons = declarations(specs)
        base = load_model(etree.tostring(root), floating_base)
        try:
            model = lib().with_constraints(base, cons)
        except ValueError as e:
            raise InvalidInput(f"constraints: {e}", "constraints") from None
        added = model.constraints[len(base.constraints):]  # welds with their placement filled in
        links = {el.get("name") for el in root.findall("link")}
        for k, c in enumerate(added):
            _write(root, model, links, k, c)
    return etree.tostring(root, xml_declaration=True, encoding="utf-8")


def _write(root, model, links: set, k: int, c) -> None:
    if type(c).__name__ == "JointCoupling":
        joint = next(j for j in root.findall("joint") if j.get("name") == c.follower)  # (a movable joint: checked)
        if joint.find("mimic") is not None:
            raise InvalidInput(f"constraints[{k}]: joint {c.follower!r} already follows another joint (<mimic>); "
                               f"a joint can follow one leader", f"constraints[{k}]")
        etree.SubElement(joint, "mimic", joint=c.leader, multiplier=repr(c.multiplier), offset=repr(c.offset))
        return
    kind = _KINDS[type(c).__name__]
    la, Ga = _link_of(model, links, c.frame_a)
    lb, Gb = _link_of(model, links, c.frame_b)
    loop = etree.SubElement(root, "loop", name=c.name, type=kind)
    if kind == "point":
        Ta, Tb = Ga @ _pose(np.eye(3), c.point_a), Gb @ _pose(np.eye(3), c.point_b)
        u = None
    elif kind == "weld":
        Ta, Tb, u = Ga @ np.array(c.placement), Gb, None
    elif np.array_equal(Ga[:3, :3], np.eye(3)) and np.array_equal(Gb[:3, :3], np.eye(3)) and c.axis == c.axis_b:
        Ta, Tb, u = Ga @ _pose(np.eye(3), c.point_a), Gb @ _pose(np.eye(3), c.point_b), c.axis  # exact numbers
    else:  # anchors whose z axes are the hinge's
        Ta = Ga @ _pose(_basis(c.axis), c.point_a)
        Tb = Gb @ _pose(_basis(c.axis_b), c.point_b)
        u = (0.0, 0.0, 1.0)
    for tag, link, T in (("link_a", la, Ta), ("link_b", lb, Tb)):
        attrs = {"name": link, "xyz": _numbers(T[:3, 3])}
        if not np.array_equal(T[:3, :3], np.eye(3)):
            attrs["rpy"] = _numbers(lib().spatial.matrix_to_rpy(T[:3, :3]))  # URDF: extrinsic x, y, z
        etree.SubElement(loop, tag, **attrs)
    if u is not None:
        etree.SubElement(loop, "axis", xyz=_numbers(u))


def _link_of(model, links: set, frame: str) -> tuple[str, np.ndarray]:
    """(a URDF link fixed to ``frame``'s body, ``frame``'s pose in that link)."""
    if frame in links:
        return frame, np.eye(4)
    body, T = model.frames[frame]  # (the library checked the name)
    for name in links:
        if name in model.frames and model.frames[name][0] == body:
            return name, np.linalg.solve(np.asarray(model.frames[name][1]), np.asarray(T))
    raise InvalidInput(f"constraints: frame {frame!r} is on no URDF link", "constraints")  # pragma: no cover


def _pose(R: np.ndarray, p: Any) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def _basis(u: Any) -> np.ndarray:
    """A rotation whose z column is the unit vector u."""
    u = np.asarray(u, float)
    t = np.array([1.0, 0, 0]) if abs(u[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(t, u)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(u, x), u])


def _numbers(x: Any) -> str:
    return " ".join(repr(float(c)) for c in x)  # repr: the float read back is the same float


def check_closed(model) -> None:
    """Refuse a model whose loops do not close near its neutral configuration (nothing it computes is valid)."""
    info = model.info.get("constraints")
    if info and not info.get("closed_near_assembly", True):
        raise InvalidInput(f"constraints: the loops cannot close: Gauss-Newton from the neutral configuration and "
                           f"nearby ones left |phi| > 1e-10 ({info['rows']} rows); check the link lengths and "
                           f"anchor points", "constraints")


# -- robot info -----------------------------------------------------------------------------------------------
def constraints_info(model) -> Optional[dict[str, Any]]:
    """The model's constraints for robot info (service.schemas.ConstraintsInfo), None when it has none."""
    if not model.constraints:
        return None
    items = []
    for c in model.constraints:
        item: dict[str, Any] = {"type": _KINDS[type(c).__name__], "name": c.name, "rows": c.rows}
        for key, value in vars(c).items():
            if key != "name" and value is not None:
                item[key] = (np.asarray(value, float).tolist() if isinstance(value, tuple)
                             else value if isinstance(value, str) else float(value))
        items.append(item)
    info = model.info.get("constraints", {})
    return {"items": items, "rows": int(info.get("rows", sum(c.rows for c in model.constraints))),
            "rank": int(info.get("rank", 0)), "mobility": int(info.get("mobility", model.nv))}


# -- the endpoints ------------------------------------------------------------------------------------------------
def forward(model, args: dict[str, Any]) -> dict[str, Any]:
    kwargs = {k: args[k] for k in ("baumgarte", "gravity") if args.get(k) is not None}
    a, lam = lib().constrained_forward_dynamics(model, args["q"], args["v"], args["tau"], **kwargs)
    return {"a": a, "lambda": lam}


def _rows(model, args: dict[str, Any]) -> int:
    return sum(c.rows for c in model.constraints)


#: the closed-loop endpoints, by URL segment (routes in service.routes.constraints)
OPERATIONS: dict[str, Operation] = {
    "constraint-residual": Operation("constraint residual", "constraint_residual", ("q",), (), "residual",
                                     per_state=_rows,
        endpoint=Endpoint(schemas.ConstraintResidualRequest, schemas.ConstraintResidualAnswer,
                          "phi(q): the loops' and couplings' residual (m,)")),
    "assemble": Operation("assembly", "assemble", ("q_guess",), ("fixed", "tol", "max_iter"), "q", iterative=True,
        endpoint=Endpoint(schemas.AssembleRequest, schemas.AssembleAnswer,
                          "q closing every loop near q_guess (Gauss-Newton); 422 when the loops cannot close")),
    "constrained-forward-dynamics": Operation("constrained forward dynamics", "constrained_forward_dynamics",
                                              ("q", "v", "tau"), ("baumgarte", "gravity"), "a", call=forward,
                                              per_state=lambda model, args: model.nv + _rows(model, args),
        endpoint=Endpoint(schemas.ConstrainedForwardDynamicsRequest, schemas.ConstrainedForwardDynamicsAnswer,
                          "accelerations a and multipliers lambda of the constrained model")),
    "constrained-inverse-dynamics": Operation("constrained inverse dynamics", "constrained_inverse_dynamics",
                                              ("q", "v", "a"), ("actuated", "gravity"), "tau",
        endpoint=Endpoint(schemas.ConstrainedInverseDynamicsRequest, schemas.TauAnswer,
                          "torques of the actuated joints for a motion the loops allow")),
}
