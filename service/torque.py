"""The HTTP torque spec (``schemas.TorqueSpec``) -> the library's torque objects: the one translation, used alike
by ``/simulate`` (in its worker process) and by ``simulate_many`` jobs (in the job runner), so that a spec that
works in one works in the other.

A spec is the ``model_dump()`` of a validated :data:`service.schemas.TorqueSpec`: a dict ``{"type": ..., ...}``
whose array fields are numpy arrays (``reference`` a nested dict). Fields left None are dropped, so that the
library's defaults apply (``posture_kp`` None would otherwise be read as NaN).

Jobs keep their arrays in an ``.npz`` and the rest as JSON: :func:`split` takes the arrays out of a spec
(``torque.<field>``, ``torque.reference.<field>``) and :func:`join` puts them back. In a job an array field may
hold one row per run: one dimension more than one run's (:data:`RUN_NDIM`); :func:`for_runs` builds each run's
torque from its row.
"""

from __future__ import annotations

from typing import Any, Optional

import numpy as np

from .errors import InvalidInput
from .library import lib

#: the ndim of each array field of ONE run, per torque type (the largest the library reads, e.g. a reference's
#: orientation (N, 3, 3)); a field with one dimension more holds one row per run of a job
RUN_NDIM: dict[str, dict[str, int]] = {
    "constant": {"tau": 1},
    "table": {"t": 1, "tau": 2},
    "pd": {"q_target": 1, "kp": 1, "kd": 1, "v_target": 1, "tau_ff": 1},
    "computed_torque": {"t": 1, "q": 2, "v": 2, "a": 2, "kp": 1, "kd": 1},
    "operational_space": {"position": 1, "orientation": 2, "kp": 1, "kd": 1, "posture": 1, "posture_kp": 1,
                          "posture_kd": 1, "reference.t": 1, "reference.position": 2, "reference.velocity": 2,
                          "reference.acceleration": 2, "reference.orientation": 3},
}
PREFIX = "torque."


def build(spec: Optional[dict[str, Any]]):
    """A spec -> the ``torque=`` argument of ``dynamics.simulate`` (see dynamics.torques). The library checks
    shapes and signs and names the field ("torque.kp: expected shape (6,), got (5,)")."""
    torques = lib().torques
    spec = {k: v for k, v in (spec or {}).items() if v is not None}
    kind = spec.pop("type", None)
    if kind is None or kind == "zero":
        return None
    if kind == "constant":
        return spec["tau"]
    if kind == "table":
        return torques.Table(**spec)
    if kind == "pd":
        return torques.PD(**spec)
    if kind == "computed_torque":
        return torques.ComputedTorque(**spec)
    if kind == "operational_space":
        return _operational_space(torques, spec)
    raise InvalidInput(f"torque.type: unknown torque type {kind!r}", "torque.type")


def _operational_space(torques, spec: dict[str, Any]):
    """{"reference": {...}} tracks a path (OperationalSpace), {"position": ...} holds a pose (Target)."""
    ref = spec.pop("reference", None)
    if (ref is None) == (spec.get("position") is None):
        raise InvalidInput("torque.reference: give either reference (a path) or position (a fixed target)",
                           "torque.reference")
    frame, kp, kd = spec.pop("frame"), spec.pop("kp"), spec.pop("kd")
    if ref is None:
        return torques.Target(frame, spec.pop("position"), spec.pop("orientation", None), kp=kp, kd=kd, **spec)
    if spec.get("orientation") is not None:
        raise InvalidInput("torque.orientation: with a reference, give reference.orientation", "torque.orientation")
    reference = torques.TaskReference(**{k: v for k, v in ref.items() if v is not None})
    return torques.OperationalSpace(frame, reference, kp, kd, **spec)


def split(spec: dict[str, Any]) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """A spec -> (its JSON part, its arrays named ``torque.<field>`` or ``torque.reference.<field>``)."""
    plain: dict[str, Any] = {}
    arrays: dict[str, np.ndarray] = {}
    for name, value in spec.items():
        if isinstance(value, dict):
            inner, inner_arrays = split(value)
            plain[name] = inner
            arrays.update({PREFIX + name + "." + k[len(PREFIX):]: v for k, v in inner_arrays.items()})
        elif isinstance(value, np.ndarray):
            arrays[PREFIX + name] = value
        elif value is not None:
            plain[name] = value
    return plain, arrays


def join(spec: dict[str, Any], arrays: dict[str, Any]) -> dict[str, Any]:
    """:func:`split`'s inverse: the spec with the arrays named ``torque.*`` among ``arrays`` put back."""
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in spec.items()}
    for key, value in arrays.items():
        if not key.startswith(PREFIX):
            continue
        *path, leaf = key[len(PREFIX):].split(".")
        node = out
        for step in path:
            node = node.setdefault(step, {})
        node[leaf] = value
    return out


def _per_run(spec: dict[str, Any]) -> dict[str, np.ndarray]:
    """The array fields of ``spec`` that hold one row per run ({"reference.position": (B, N, 3)})."""
    ndims = RUN_NDIM.get(spec.get("type"), {})
    found = {}
    for path, ndim in ndims.items():
        node: Any = spec
        for step in path.split("."):
            node = node.get(step) if isinstance(node, dict) else None
        if node is not None and np.ndim(node) == ndim + 1:
            found[path] = np.asarray(node)
    return found


def runs(spec: Optional[dict[str, Any]]) -> dict[str, int]:
    """{field: rows} of the fields holding one row per run."""
    return {path: x.shape[0] for path, x in _per_run(spec or {}).items()}


def _row(spec: dict[str, Any], per_run: dict[str, np.ndarray], k: int) -> dict[str, Any]:
    arrays = {PREFIX + path: x[k] for path, x in per_run.items()}
    return join(spec, arrays)


def for_runs(spec: Optional[dict[str, Any]], lo: int, hi: int):
    """The torque of runs [lo, hi) of a job: one object when no field holds rows per run, else one per run."""
    if spec is None:
        return None
    per_run = _per_run(spec)
    if not per_run:
        return build(spec)
    return [build(_row(spec, per_run, k)) for k in range(lo, hi)]


def check(model, spec: Optional[dict[str, Any]], total: int) -> None:
    """At a job's submission: the rows per run agree with ``total``, and the first run's torque is one the
    library accepts for ``model`` (its message names the field); a ValueError otherwise."""
    if spec is None:
        return
    for path, rows in runs(spec).items():
        if rows != total:
            raise InvalidInput(f"torque.{path}: {rows} rows, one per run, but the job has {total} runs",
                               f"torque.{path}")
    torque = for_runs(spec, 0, 1)
    lib().torques.make_source(model, torque[0] if isinstance(torque, list) else torque)
