"""The HTTP contact spec (``schemas.ContactSpec``) -> ``dynamics.Contact``: the one translation, used alike by
``/simulate`` (in its worker process) and by ``simulate_many`` jobs (in the job runner), as :mod:`service.torque`
is for torques.

A spec is the ``model_dump(exclude_none=True)`` of a validated :class:`~service.schemas.ContactSpec`: plain
lists, numbers, strings and booleans (JSON as it is, so a job keeps it in its spec). Every declaration is built
here with its path in the request, so that a library refusal ("Sphere.radius: expected a finite number > 0")
comes back as a 422 naming ``contact.geometries[2]``; what only the model can tell (an unknown frame, a pair
naming no geometry) the library finds when the simulation resolves the contact, and :func:`qualify` puts
``contact.`` in front of its message.

The answer's side: :func:`samples` turns ``Trajectory.contacts`` (``dynamics.contact.outputs.ContactSamples``)
into one row per active contact, arrays named ``contacts.<field>``, plus the pair names; :func:`run_samples` does
the same for every run of ``simulate_many`` (``Trajectories.contacts``), with a ``contacts.run`` column, for
jobs; :func:`robot_geometry` describes a model's collision geometry for ``GET /v1/robots/{id}``.
"""

from __future__ import annotations

import json
from typing import Any, Optional

import numpy as np

from .errors import InvalidInput
from .library import lib

#: the fields of a Contact whose library messages start with their own name ("pairs[3]: ...")
_FIELDS = ("ground", "friction", "objects", "world", "geometries", "geometry", "materials", "pairs",
           "self_collision", "exclude", "Ground", "HalfSpace", "Sphere", "Box", "Capsule", "Cylinder",
           "ContactPoint", "Material")
#: the HTTP type of a geometry -> the library's declaration and its arguments besides frame and name
_PRIMITIVES = {"sphere": ("Sphere", ("radius", "offset")), "box": ("Box", ("size", "pose")),
               "capsule": ("Capsule", ("radius", "length", "pose")),
               "cylinder": ("Cylinder", ("radius", "length", "pose")), "point": ("ContactPoint", ("point",))}
#: the fields of ContactSamples sent per active contact as ``contacts.<name>``
SAMPLE_FIELDS = ("point", "normal", "normal_force", "friction", "depth", "slip")


def _made(where: str, make, *args, **kwargs):
    """``make(*args, **kwargs)``, its InputError re-raised naming ``where`` (the request's path)."""
    try:
        return make(*args, **kwargs)
    except (ValueError, TypeError) as e:
        message = str(e)
        raise InvalidInput(f"{where}: {message}", where) from None


def _primitive(spec: dict[str, Any], where: str):
    if spec.get("frame") is None:
        raise InvalidInput(f"{where}.frame: missing (required): the frame of the robot the {spec['type']} is fixed to",
                           f"{where}.frame")
    kind = spec["type"]
    cls, fields = _PRIMITIVES[kind]
    args = {name: spec[name] for name in fields if spec.get(name) is not None}
    if "pose" in args:
        args["pose"] = np.asarray(args["pose"], dtype=float)
    return _made(where, getattr(lib(), cls), spec["frame"], name=spec.get("name"), **args)


def _object(spec: dict[str, Any], where: str):
    if spec["type"] == "half_space":
        return _made(where, lib().HalfSpace, spec["normal"], spec.get("offset", 0.0), name=spec.get("name"))
    if spec.get("frame") not in (None, "world"):
        raise InvalidInput(f"{where}.frame: a world object is fixed to 'world', got {spec['frame']!r:.60}; the "
                           f"robot's own geometry goes in contact.geometries", f"{where}.frame")
    return _primitive({**spec, "frame": "world"}, where)


def _material(spec: Any, where: str):
    """A friction coefficient stays a number (the library reads it as Material(mu, mu)); an object a Material."""
    if spec is None or isinstance(spec, (int, float)):
        return spec
    return _made(where, lib().Material, **spec)


def _ground(spec: Any):
    if spec is True:
        return lib().Ground()
    if spec is False:
        return None
    return _made("contact.ground", lib().Ground, spec.get("normal", (0.0, 0.0, 1.0)), spec.get("height", 0.0))


def build(spec: Optional[dict[str, Any]]):
    """A spec -> the ``contact=`` argument of ``dynamics.simulate`` (None for none). Fields left out keep the
    library's defaults."""
    if spec is None:
        return None
    kwargs: dict[str, Any] = {"ground": _ground(spec.get("ground", True))}
    if spec.get("friction") is not None:
        kwargs["friction"] = _material(spec["friction"], "contact.friction")
    if spec.get("geometries") is not None:
        kwargs["geometries"] = [_primitive(g, f"contact.geometries[{k}]") for k, g in enumerate(spec["geometries"])]
    kwargs["objects"] = [_object(o, f"contact.objects[{k}]") for k, o in enumerate(spec.get("objects", ()))]
    kwargs["materials"] = {name: _material(m, f"contact.materials[{name!r}]")
                           for name, m in (spec.get("materials") or {}).items()}
    if spec.get("pairs") is not None:
        kwargs["pairs"] = [tuple(p) for p in spec["pairs"]]
    kwargs["exclude"] = [tuple(p) for p in spec.get("exclude", ())]
    return _made("contact", lib().Contact, self_collision=bool(spec.get("self_collision", False)),
                 outputs=tuple(spec.get("outputs", ())), **kwargs)


def check_frames(model, spec: Optional[dict[str, Any]], prefix: str = "contact") -> None:
    """Every declared geometry's frame is one of the model's (an InvalidInput naming the geometry otherwise): told
    by the server at once, before a worker resolves the rest (materials and pairs by name, in the library)."""
    if spec is None:
        return
    frames = model.frames
    for k, g in enumerate(spec.get("geometries") or ()):
        frame = g.get("frame")
        if frame is not None and frame != "world" and frame not in frames:
            import difflib
            close = difflib.get_close_matches(frame, list(frames), n=3, cutoff=0.5)
            where = f"{prefix}.geometries[{k}].frame"
            raise InvalidInput(f"{where}: the robot has no frame named {frame!r:.60}; "
                               + (f"closest: {close}" if close else f"its frames are {list(frames)[:12]}"), where)


def qualify(message: str) -> str:
    """A library message about a contact field ("pairs[0]: ...", "Sphere.radius: ...") as the request names it
    ("contact.pairs[0]: ..."); any other message unchanged."""
    head = message.split(":", 1)[0].split("[", 1)[0].split(".", 1)[0].split(" ", 1)[0]
    return f"contact.{message}" if head in _FIELDS else message


def samples(contacts) -> dict[str, Any]:
    """``Trajectory.contacts`` (``ContactSamples``: (T, K) rows, ``count`` of them in use per sample) -> the
    answer's active contacts, one row each in sample order: ``contacts.sample`` (N,) the sample index,
    ``contacts.pair`` (N,) the index into ``contacts.pairs`` (the geometry names of each candidate pair), and
    ``contacts.point``, ``normal``, ``normal_force``, ``friction``, ``depth``, ``slip`` (world frame)."""
    if contacts is None:
        return {}
    pair = np.asarray(contacts.pair)
    sample, row = np.nonzero(pair >= 0)
    out: dict[str, Any] = {"contacts.sample": sample.astype(np.int64), "contacts.pair": pair[sample, row]}
    for name in SAMPLE_FIELDS:
        out[f"contacts.{name}"] = np.ascontiguousarray(np.asarray(getattr(contacts, name))[sample, row])
    out["contacts.pairs"] = [list(p) for p in contacts.pairs]
    return out


#: trailing shape of each field of a contact row (``contacts.<name>`` is (N, *shape))
SAMPLE_SHAPES = {"point": (3,), "normal": (3,), "normal_force": (), "friction": (3,), "depth": (), "slip": (3,)}
#: the arrays of a simulate_many job's contacts, one row per active contact of any run (the run's index first)
RUN_MEMBERS = ("contacts.run", "contacts.sample", "contacts.pair", *(f"contacts.{n}" for n in SAMPLE_FIELDS))


def run_samples(contacts, first: int = 0) -> dict[str, Any]:
    """``Trajectories.contacts`` of ``simulate_many`` (every field but ``pairs`` with a leading run axis (B, T,
    ...)) -> the active contacts of every run as in :func:`samples`, plus ``contacts.run`` (N,) (``first`` + the
    run's index), in run then sample order; ``contacts.pairs`` None when no run kept contacts (``contacts``
    None: every run failed). A run's rows are exactly what :func:`samples` gives for it alone."""
    if contacts is None:
        out: dict[str, Any] = {name: np.zeros(0, np.int64) for name in RUN_MEMBERS[:3]}
        out.update({f"contacts.{n}": np.zeros((0, *SAMPLE_SHAPES[n])) for n in SAMPLE_FIELDS})
        return {**out, "contacts.pairs": None}
    pair = np.asarray(contacts.pair)
    run, sample, row = np.nonzero(pair >= 0)
    out = {"contacts.run": run.astype(np.int64) + first, "contacts.sample": sample.astype(np.int64),
           "contacts.pair": pair[run, sample, row]}
    for name in SAMPLE_FIELDS:
        out[f"contacts.{name}"] = np.ascontiguousarray(np.asarray(getattr(contacts, name))[run, sample, row])
    out["contacts.pairs"] = [list(p) for p in contacts.pairs]
    return out


def robot_geometry(model) -> list[dict[str, Any]]:
    """``model.collision_geometry`` as JSON: name, body (a body name, None for the world), frame, kind, size,
    pose (4x4 in the body's frame)."""
    names = model.body_names
    return [{"name": g.name, "body": names[g.body] if g.body >= 0 else None, "frame": g.frame, "kind": g.kind,
             "size": [float(x) for x in g.size], "pose": np.asarray(g.pose).tolist()}
            for g in getattr(model, "collision_geometry", ())]


def from_npz(value: Any) -> Any:
    """In an .npz body the contact travels as a JSON string (like the torque spec)."""
    if isinstance(value, str) and value.lstrip()[:1] == "{":
        try:
            return json.loads(value)
        except json.JSONDecodeError:
            raise InvalidInput("contact: not a JSON object", "contact") from None
    return value
