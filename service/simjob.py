"""One simulation request -> ``dynamics.simulate`` call (runs inside a worker process).

The HTTP torque spec (``{"type": "zero" | "constant" | "table" | "pd" | "computed_torque", ...}``) is turned into
the library's torque objects here, so that the route stays free of numeric code and the worker receives plain
arrays and dicts (cheap to pickle, nothing callable crosses the process boundary).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def _finite_report(obj: Any) -> Any:
    """JSON has no NaN or infinity: such numbers in the report become null."""
    if isinstance(obj, dict):
        return {str(k): _finite_report(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite_report(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _finite_report(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    return str(obj)


def build_torque(model, spec: dict[str, Any] | None):
    """The HTTP torque spec -> the library's torque argument (see dynamics.torques)."""
    import dynamics

    torques = getattr(dynamics, "torques", None)
    if spec is None or spec["type"] == "zero":
        return None
    kind = spec["type"]
    if torques is None:
        raise ValueError(f"torque.type: {kind!r} needs dynamics.torques, which this build does not have")
    raise ValueError(f"torque.type: {kind!r} is not supported")  # replaced once dynamics.torques lands


def run_simulation(model, job: dict[str, Any]) -> dict[str, Any]:
    import dynamics

    torque = build_torque(model, job.get("torque"))
    options = {k: v for k, v in job["options"].items() if v is not None}
    if torque is not None:
        options["torque"] = torque
    traj = dynamics.simulate(model, job["q0"], job["v0"], job["duration"], **options)
    out = {name: np.asarray(getattr(traj, name)) for name in ("t", "q", "v", "tau")}
    out["report"] = _finite_report(dict(getattr(traj, "report", {}) or {}))
    return out
