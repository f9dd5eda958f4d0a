"""Robot management behind the routes: upload (check, load, store), list, describe, delete.

These functions run in a compute thread (they parse XML, build models and fsync files) and take the
process's :class:`service.app.Services` as their first argument.
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Any, Optional

from lxml import etree

from .codec import _jsonable, finite_or_none
from .compute import Loaded
from .errors import ApiError, bad_input

if TYPE_CHECKING:  # pragma: no cover
    from .app import Services


def check_xml(data: bytes, *, max_bytes: int, max_depth: int) -> None:
    """Refuse what no URDF needs before the library sees it: oversize, DOCTYPE/ENTITY, deep nesting, bad XML.

    The library's own parser refuses DTDs and entities too; this is a second, independent wall, and it
    streams so that a deep document is refused at the first element past ``max_depth``.
    """
    if len(data) > max_bytes:
        raise ApiError(413, f"urdf: {len(data)} bytes is over the limit of {max_bytes} (DYNAMICS_MAX_URDF_BYTES)",
                       code="too_large", field="urdf")
    lowered = data.lower()
    if b"<!doctype" in lowered or b"<!entity" in lowered:
        raise bad_input("urdf: DOCTYPE and ENTITY declarations are not allowed", "urdf")
    parser = etree.XMLPullParser(events=("start", "end"), resolve_entities=False, no_network=True,
                                 load_dtd=False, huge_tree=False, recover=False)
    depth = 0
    try:
        for start in range(0, len(data), 1 << 16):
            parser.feed(data[start:start + (1 << 16)])
            for event, _ in parser.read_events():
                depth += 1 if event == "start" else -1
                if depth > max_depth:
                    raise bad_input(f"urdf: XML nested deeper than {max_depth} elements", "urdf")
        parser.close()
    except etree.XMLSyntaxError as e:
        raise bad_input(f"urdf: not well-formed XML ({e})", "urdf") from None


def register_robot(svc: "Services", urdf: bytes, name: Optional[str], floating_base: bool,
                   owner: Optional[str]) -> dict[str, Any]:
    import dynamics

    s = svc.settings
    check_xml(urdf, max_bytes=s.max_urdf_bytes, max_depth=s.max_xml_depth)
    try:
        text = urdf.decode("utf-8")
    except UnicodeDecodeError:
        raise bad_input("urdf: not UTF-8 text", "urdf") from None
    try:
        model = dynamics.load_urdf(urdf, floating_base=floating_base)  # bytes: never read as a file path
    except ValueError as e:  # URDFError names the link or joint
        raise bad_input(f"urdf: {e}" if not str(e).lower().startswith("urdf") else str(e), "urdf") from None
    if model.nv > s.max_dof:
        raise bad_input(f"urdf: {model.nv} degrees of freedom is over the limit of {s.max_dof} "
                        f"(DYNAMICS_MAX_DOF)", "urdf")
    name = name or model.name
    record, _created = svc.store.put(text, name=name, floating_base=floating_base, owner=owner,
                                     summary=_summary(model))
    # The model we just built is the one a request would build: keep it.
    svc.compute.cache.get_or_load((record.id, ()), lambda: Loaded.of(model))
    info = _public(record.id, record.name, False, record.floating_base, record.summary)
    info["summary"] = model_summary(model)
    return info


def _summary(model) -> dict[str, Any]:
    return {"nq": int(model.nq), "nv": int(model.nv), "joint_names": list(model.joint_names),
            "bodies": list(model.body_names), "warnings": list(model.warnings)}


def _public(rid: str, name: str, bundled: bool, floating_base: bool, summary: dict[str, Any]) -> dict[str, Any]:
    return {"id": rid, "name": name, "nq": summary["nq"], "nv": summary["nv"], "floating_base": floating_base,
            "bundled": bundled, "joint_names": summary["joint_names"], "bodies": summary["bodies"],
            "warnings": summary["warnings"]}


def list_robots(svc: "Services") -> list[dict[str, Any]]:
    out = []
    for rid in svc.store.bundled_ids():
        try:
            model = svc.compute.model(rid)
        except ApiError:
            continue
        except ValueError:  # a bundled URDF the library refuses: leave it out rather than fail the list
            continue
        out.append(_public(rid, rid, True, False, _summary(model)))
    for rid in svc.store.uploaded_ids():
        rec = svc.store.get(rid)
        if rec is not None:
            out.append(_public(rec.id, rec.name, False, rec.floating_base, rec.summary))
    return out


def robot_info(svc: "Services", rid: str) -> dict[str, Any]:
    rec = svc.compute.record(rid)
    try:
        model = svc.compute.model(rid)
    except ValueError as e:
        raise bad_input(f"urdf: {e}", "urdf") from None
    joints = []
    for i, jname in enumerate(model.joint_names):
        k, n = int(model.v_index[i]), int(model.nv_joint[i])
        sl = slice(k, k + n)
        parent = int(model.parents[i])
        joints.append({
            "name": jname, "type": model.joint_types[i], "body": model.body_names[i],
            "parent": model.body_names[parent] if parent >= 0 else None,
            "q_index": int(model.q_index[i]), "v_index": k, "nq": int(model.nq_joint[i]), "nv": n,
            "lower": [finite_or_none(x) for x in model.lower[sl]],
            "upper": [finite_or_none(x) for x in model.upper[sl]],
            "effort_limit": [finite_or_none(x) for x in model.effort_limit[sl]],
            "velocity_limit": [finite_or_none(x) for x in model.velocity_limit[sl]],
            "damping": [float(x) for x in model.damping[sl]],
            "friction": [float(x) for x in model.friction[sl]],
        })
    info = _public(rec.id, rec.name, rec.bundled, rec.floating_base, _summary(model))
    info["joints"] = joints
    info["gravity"] = [float(x) for x in model.gravity]
    info["summary"] = model_summary(model)
    return info


def model_summary(model) -> dict[str, Any]:
    """``model.summary()``: URDF links and joints, bodies kept, fixed joints merged, links pruned, locked joints,
    warnings. JSON-safe by the library's contract; numpy scalars are turned into numbers all the same."""
    return json.loads(json.dumps(model.summary(), default=_jsonable))


def delete_robot(svc: "Services", rid: str, owner: Optional[str]) -> None:
    rec = svc.compute.record(rid)
    if rec.bundled:
        raise ApiError(403, f"robot: {rid!r} is bundled with the service and cannot be deleted",
                       code="read_only", field="robot")
    if svc.settings.api_keys and rec.owner is not None and rec.owner != owner:
        raise ApiError(403, f"robot: {rid!r} was uploaded with another API key; only that key can delete it",
                       code="forbidden", field="robot")
    svc.store.delete(rid)
    svc.compute.cache.discard(rid)
