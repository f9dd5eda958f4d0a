"""The robots a server knows: upload (check, load, store), list, describe, delete.

The bundled robots (read-only) and the uploaded ones (in the :class:`~service.store.RobotStore`), described from
their compiled models. Every method may parse XML, build a model or fsync a file: call them from a worker thread.
"""

from __future__ import annotations

import difflib
import unicodedata

import json
from typing import Any, Optional

import numpy as np
from lxml import etree

from .codec import finite_or_none, jsonable
from .constraints import check_closed, constraints_info, declare
from .contact import robot_geometry
from .errors import Conflict, Forbidden, InvalidInput, NotFound, TooLarge, echo
from .inspection import inspection
from .models import Models, collision_geometry, load_model
from .schemas import MAX_NAME
from .settings import Settings
from .store import IndexEntry, RobotStore, robot_id


def check_xml(data: bytes, *, max_bytes: int, max_depth: int, max_links: int = 1024) -> None:
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
    counts = {"link": 0, "joint": 0}
    try:
        for start in range(0, len(data), 1 << 16):
            parser.feed(data[start:start + (1 << 16)])
            for event, element in parser.read_events():
                depth += 1 if event == "start" else -1
                if depth > max_depth:
                    raise InvalidInput(f"urdf: XML nested deeper than {max_depth} elements", "urdf")
                if event == "start" and depth == 2 and element.tag in counts:
                    counts[element.tag] += 1
                    if counts[element.tag] > max_links:
                        raise TooLarge(f"urdf: more than {max_links} <{element.tag}> elements, over the limit "
                                       f"(DYNAMICS_MAX_LINKS)", "urdf")
                if event == "end" and depth == 1:
                    element.clear()  # (a robot's children are not kept: memory stays flat)
        parser.close()
    except etree.XMLSyntaxError as e:
        raise InvalidInput(f"urdf: not well-formed XML ({e})", "urdf") from None


#: Unicode categories no robot name may hold: control characters (Cc); format characters (Cf: the bidirectional
#: overrides and isolates U+202A-U+202E and U+2066-U+2069, the marks U+200E and U+200F, zero-width characters);
#: line and paragraph separators. They make a listing show another text than the name a request must send.
REFUSED_CATEGORIES = frozenset({"Cc", "Cf", "Zl", "Zp"})


def check_name(name: str, given: bool) -> None:
    """A robot's name as a listing shows it and a path addresses it (``/v1/robots/{name}/...``): not empty, no
    leading or trailing space, no '/', '\\' or '..' (files are stored by id, so nothing is traversed, but such a
    name reads as a path) and no character of :data:`REFUSED_CATEGORIES`; 422 naming ``name`` otherwise.
    ``given``: the caller's (?name= or the JSON body's), else the URDF's robot name."""
    whose = "" if given else "the URDF's robot name "
    fix = "choose another name" if given else "give the robot a name (?name=...)"
    if not name.strip():
        empty = "empty; give a name, or leave it out to use the URDF's robot name" if given else \
            "the URDF's robot name is empty; give the robot a name (?name=...)"
        raise InvalidInput(f"name: {empty}", "name")
    if name != name.strip():
        raise InvalidInput(f"name: {whose}{echo(name)} starts or ends with a space; {fix}", "name")
    for part in ("/", "\\", ".."):
        if part in name:
            raise InvalidInput(f"name: {whose}{echo(name)} contains {part!r}; a name is one segment of a path "
                               f"(/v1/robots/{{name}}): {fix}", "name")
    for c in name:
        if unicodedata.category(c) in REFUSED_CATEGORIES:
            raise InvalidInput(f"name: {whose}{echo(name)} contains U+{ord(c):04X} "
                               f"({unicodedata.name(c, 'a control character')}): control and formatting characters "
                               f"(bidirectional overrides among them) would show another name than the robot's; "
                               f"{fix}", "name")


def model_summary(model) -> dict[str, Any]:
    """``model.summary()``: URDF links and joints, bodies kept, fixed joints merged, links pruned, locked joints,
    warnings. JSON-safe by the library's contract; numpy scalars are turned into numbers all the same."""
    return json.loads(json.dumps(model.summary(), default=jsonable))


def _stored_summary(model) -> dict[str, Any]:
    """What the store keeps of a model, to list robots without building them."""
    return {"nq": int(model.nq), "nv": int(model.nv), "joint_names": list(model.joint_names),
            "bodies": list(model.body_names), "warnings": list(model.warnings),
            "floating_base": bool(model.floating_base)}


def _public(rid: str, name: str, bundled: bool, floating_base: bool, summary: dict[str, Any]) -> dict[str, Any]:
    """A robot's public record. ``floating_base`` is the model's (as in its summary: a floating joint below the
    root floats it too), not only the upload option; records stored before it was kept fall back to the option."""
    return {"id": rid, "name": name, "nq": summary["nq"], "nv": summary["nv"],
            "floating_base": bool(summary.get("floating_base", floating_base)),
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
        return self.store_upload(urdf, name, floating_base, owner, constraints, mimic)[0]

    def store_upload(self, urdf: bytes, name: Optional[str], floating_base: bool, owner: Optional[str],
                     constraints: Optional[list[Any]] = None, mimic: Optional[str] = None
                     ) -> tuple[dict[str, Any], bool]:
        """Check, load and store a URDF: (its description, whether it was created). The same upload again
        (same key, document, name and options) is the same robot: (description, False). ``constraints``
        (schemas.ConstraintSpec) and ``mimic`` are written into the stored document (service.constraints.declare)."""
        s = self.settings
        explicit = name is not None  # (an empty ?name= is given, and refused: not the URDF's name in disguise)
        if explicit:
            check_name(name, True)  # (before the URDF is parsed)
        check_xml(urdf, max_bytes=s.max_urdf_bytes, max_depth=s.max_xml_depth, max_links=s.max_links)
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
        if not explicit:
            name = model.name[:MAX_NAME]  # (a URDF's name is capped like a given one)
            check_name(name, False)
        rid = robot_id(text, name=name, floating_base=floating_base, owner=owner)
        if self.store.lookup(rid) is None:
            self._check_new(name, explicit, owner)
        record, created = self.store.put(text, name=name, floating_base=floating_base, owner=owner,
                                         summary=_stored_summary(model))
        self.models.keep(record.id, model)  # the model a request would build
        info = _public(record.id, record.name, False, record.floating_base, record.summary)
        info["summary"] = model_summary(model)
        info["constraints"] = constraints_info(model)
        return info, created

    def _check_new(self, name: str, explicit: bool, owner: Optional[str]) -> None:
        """Before a new robot is stored: a name given at upload is unique per key (409), and the key's quotas."""
        s = self.settings
        if explicit:
            taken = [e.id for e in self.store.index().values() if e.owner == owner and e.name == name]
            if taken or name in self.store.bundled_ids():
                raise Conflict(f"name: {echo(name)} is already the name of robot {(taken or [name])[0]}; delete it "
                               f"first or choose another name", "name")
        robots, size = self.store.usage(owner)
        if robots >= s.max_robots_per_key:
            raise TooLarge(f"robots: this key already stores {robots} robots, the limit "
                           f"(DYNAMICS_MAX_ROBOTS_PER_KEY); delete some first", "robots", code="quota_exceeded")
        if size >= s.max_store_bytes:
            raise TooLarge(f"robots: this key's robots take {size} bytes, over the limit of {s.max_store_bytes} "
                           f"(DYNAMICS_MAX_STORE_BYTES); delete some first", "robots", code="quota_exceeded")

    # -- access: robots belong to the key that uploaded them -------------------------------------------------
    def _visible(self, entry: IndexEntry, owner: Optional[str]) -> bool:
        """Keys off: every robot. Keys on: the caller's, and those uploaded while keys were off (read-only)."""
        return not self.settings.api_keys or entry.owner == owner or entry.owner is None

    def resolve(self, ref: str, owner: Optional[str]) -> str:
        """A robot's id from an id or a name, as the caller may see it; 404 otherwise (another key's robots are
        not found rather than forbidden: their existence is not told). Reads no URDF: fit for the event loop."""
        bundled = self.store.bundled_id(ref)
        if bundled is not None:
            return bundled
        entry = self.store.lookup(ref) if len(ref) <= 64 else None
        if entry is not None and self._visible(entry, owner):
            return entry.id
        named = [e for e in self.store.index().values() if e.name == ref and self._visible(e, owner)]
        own = [e for e in named if e.owner == owner] or named
        if len(own) == 1:
            return own[0].id
        if len(own) > 1:
            raise Conflict(f"robot: {echo(ref)} names {len(own)} robots ({', '.join(e.id for e in own[:5])}); "
                           f"use an id", "robot")
        raise NotFound(f"robot: no robot with id or name {echo(ref)}{self._closest(ref, owner)}", "robot")

    def _closest(self, ref: str, owner: Optional[str]) -> str:
        """"; did you mean 'planar_2r'?" from the names this caller may use, or "; bundled robots are [...]"."""
        names = self.store.bundled_ids() + sorted({e.name for e in self.store.index().values()
                                                   if self._visible(e, owner)})
        close = difflib.get_close_matches(ref[:MAX_NAME].replace("-", "_"), names, n=3, cutoff=0.6)
        if close:
            return f"; did you mean {' or '.join(repr(c) for c in close)}?"
        return f"; bundled robots are {self.store.bundled_ids()} (GET /v1/robots lists yours)"

    def list_robots(self, owner: Optional[str] = None) -> list[dict[str, Any]]:
        out = []
        for rid in self.store.bundled_ids():
            try:
                model = self.models.loaded(rid).model
            except InvalidInput:  # a bundled URDF the library refuses: leave it out rather than fail the list
                continue
            out.append(_public(rid, rid, True, False, _stored_summary(model)))
        for rid, e in sorted(self.store.index().items()):
            if self._visible(e, owner):
                out.append(_public(e.id, e.name, False, e.floating_base, e.summary))
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
        info["collision_geometry"] = robot_geometry(model)
        return info

    def inspect(self, rid: str) -> dict[str, Any]:
        """:meth:`describe` and what the inspector page draws (:func:`service.inspection.inspection`)."""
        info = self.describe(rid)
        loaded = self.models.loaded(rid)
        info.update(inspection(loaded.model, geometry=collision_geometry(loaded)))
        return info

    def delete(self, rid: str, owner: Optional[str]) -> None:
        rec = self.models.record(rid)
        if rec.bundled:
            raise Forbidden(f"robot: {rid!r} is bundled with the service and cannot be deleted", "robot",
                            code="read_only")
        if self.settings.api_keys and rec.owner != owner:  # (resolve() already hid other keys' robots)
            raise Forbidden(f"robot: {rid!r} was uploaded without an API key; with keys on it is read-only",
                            "robot", code="read_only")
        self.store.delete(rid)
        self.models.forget(rid)
