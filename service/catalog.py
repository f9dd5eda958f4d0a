"""The robots a server knows: upload (check, load, store), list, describe, delete.

The bundled robots (read-only) and the uploaded ones (in the :class:`~service.store.RobotStore`), described from
their compiled models. Every method may parse XML, build a model or fsync a file: call them from a worker thread.
"""

from __future__ import annotations

import json
from typing import Any, Optional

import numpy as np
from lxml import etree

from .codec import finite_or_none, jsonable
from .constraints import check_closed, constraints_info, declare
from .errors import Forbidden, InvalidInput, TooLarge
from .models import Models, load_model
from .settings import Settings
from .store import RobotStore


def check_xml(data: bytes, *, max_bytes: int, max_depth: int) -> None:
    """Refuse what no URDF needs before the library sees it: oversize, DOCTYPE/ENTITY, deep nesting, bad XML.

    The library's own parser refuses DTDs and entities too; this is a second, independent wall, and it
    streams so that a deep document is refused at the first element past ``max_depth``.
    """
    if len(data) > max_bytes:
        raise TooLarge(f"urdf: {len(data)} bytes is over the limit of {max_bytes} (DYNAMICS_MAX_URDF_BYTES)", "urdf")
    lowered = data.lower()
    if b"<!doctype" in lowered or b"<!entity" in lowered:
        raise InvalidInput("urdf: DOCTYPE and ENTITY declarations are not allowed", "urdf")
    parser = etree.XMLPullParser(events=("start", "end"), resolve_entities=False, no_network=True,
                                 load_dtd=False, huge_tree=False, recover=False)
    depth = 0
    try:
        for start in range(0, len(data), 1 << 16):
            parser.feed(data[start:start + (1 << 16)])
            for event, _ in parser.read_events():
                depth += 1 if event == "start" else -1
                if depth > max_depth:
                    raise InvalidInput(f"urdf: XML nested deeper than {max_depth} elements", "urdf")
        parser.close()
    except etree.XMLSyntaxError as e:
        raise InvalidInput(f"urdf: not well-formed XML ({e})", "urdf") from None


def model_summary(model) -> dict[str, Any]:
    """``model.summary()``: URDF links and joints, bodies kept, fixed joints merged, links pruned, locked joints,
    warnings. JSON-safe by the library's contract; numpy scalars are turned into numbers all the same."""
    return json.loads(json.dumps(model.summary(), default=jsonable))


def _stored_summary(model) -> dict[str, Any]:
    """What the store keeps of a model, to list robots without building them."""
    return {"nq": int(model.nq), "nv": int(model.nv), "joint_names": list(model.joint_names),
            "bodies": list(model.body_names), "warnings": list(model.warnings)}


def _public(rid: str, name: str, bundled: bool, floating_base: bool, summary: dict[str, Any]) -> dict[str, Any]:
    return {"id": rid, "name": name, "nq": summary["nq"], "nv": summary["nv"], "floating_base": floating_base,
            "bundled": bundled, "joint_names": summary["joint_names"], "bodies": summary["bodies"],
            "warnings": summary["warnings"]}


def _joint(model, i: int) -> dict[str, Any]:
    k, n = int(model.v_index[i]), int(model.nv_joint[i])
    sl = slice(k, k + n)
    parent = int(model.parents[i])
    return {
        "name": model.joint_names[i], "type": model.joint_types[i], "body": model.body_names[i],
        "parent": model.body_names[parent] if parent >= 0 else None,
        "q_index": int(model.q_index[i]), "v_index": k, "nq": int(model.nq_joint[i]), "nv": n,
        "lower": [finite_or_none(x) for x in model.lower[sl]],
        "upper": [finite_or_none(x) for x in model.upper[sl]],
        "effort_limit": [finite_or_none(x) for x in model.effort_limit[sl]],
        "velocity_limit": [finite_or_none(x) for x in model.velocity_limit[sl]],
        "damping": [float(x) for x in model.damping[sl]],
        "friction": [float(x) for x in model.friction[sl]],
    }


def _inertial(model) -> dict[str, Any]:
    """The bodies' masses, centres of mass and inertias (the library's names and frames), and every frame."""
    frames = [{"name": name, "body": model.body_names[b] if b >= 0 else None, "placement": np.asarray(T).tolist()}
              for name, (b, T) in model.frames.items()]
    return {"total_mass": model.total_mass, "masses": model.masses.tolist(), "coms": model.coms.tolist(),
            "inertias": model.inertias.tolist(), "frames": frames}


class Catalog:
    def __init__(self, settings: Settings, store: RobotStore, models: Models):
        self.settings = settings
        self.store = store
        self.models = models

    def upload(self, urdf: bytes, name: Optional[str], floating_base: bool, owner: Optional[str],
               constraints: Optional[list[Any]] = None, mimic: Optional[str] = None) -> dict[str, Any]:
        """``constraints`` (schemas.ConstraintSpec) and ``mimic`` are written into the stored document
        (service.constraints.declare)."""
        s = self.settings
        check_xml(urdf, max_bytes=s.max_urdf_bytes, max_depth=s.max_xml_depth)
        urdf = declare(urdf, floating_base, constraints, mimic)
        try:
            text = urdf.decode("utf-8")
        except UnicodeDecodeError:
            raise InvalidInput("urdf: not UTF-8 text", "urdf") from None
        model = load_model(urdf, floating_base)
        if model.nv > s.max_dof:
            raise InvalidInput(f"urdf: {model.nv} degrees of freedom is over the limit of {s.max_dof} "
                               f"(DYNAMICS_MAX_DOF)", "urdf")
        check_closed(model)
        record, _created = self.store.put(text, name=name or model.name, floating_base=floating_base, owner=owner,
                                          summary=_stored_summary(model))
        self.models.keep(record.id, model)  # the model a request would build
        info = _public(record.id, record.name, False, record.floating_base, record.summary)
        info["summary"] = model_summary(model)
        info["constraints"] = constraints_info(model)
        return info

    def list_robots(self) -> list[dict[str, Any]]:
        out = []
        for rid in self.store.bundled_ids():
            try:
                model = self.models.loaded(rid).model
            except InvalidInput:  # a bundled URDF the library refuses: leave it out rather than fail the list
                continue
            out.append(_public(rid, rid, True, False, _stored_summary(model)))
        for rid in self.store.uploaded_ids():
            rec = self.store.get(rid)
            if rec is not None:
                out.append(_public(rec.id, rec.name, False, rec.floating_base, rec.summary))
        return out

    def describe(self, rid: str) -> dict[str, Any]:
        rec = self.models.record(rid)
        model = self.models.loaded(rid).model
        info = _public(rec.id, rec.name, rec.bundled, rec.floating_base, _stored_summary(model))
        info["joints"] = [_joint(model, i) for i in range(len(model.joint_names))]
        info["gravity"] = [float(x) for x in model.gravity]
        info.update(_inertial(model))
        info["summary"] = model_summary(model)
        info["constraints"] = constraints_info(model)
        return info

    def delete(self, rid: str, owner: Optional[str]) -> None:
        rec = self.models.record(rid)
        if rec.bundled:
            raise Forbidden(f"robot: {rid!r} is bundled with the service and cannot be deleted", "robot",
                            code="read_only")
        if self.settings.api_keys and rec.owner is not None and rec.owner != owner:
            raise Forbidden(f"robot: {rid!r} was uploaded with another API key; only that key can delete it", "robot")
        self.store.delete(rid)
        self.models.forget(rid)
