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
    """The HTTP torque spec -> the ``torque=`` argument of dynamics.simulate (see dynamics.torques).

    The library checks shapes and signs and names the field ("torque.kp: expected shape (6,), got (5,)").
    """
    from dynamics import torques

    if spec is None:
        return None
    kind = spec["type"]
    if kind == "zero":
        return None
    if kind == "constant":
        return spec["tau"]
    if kind == "table":
        return torques.Table(spec["t"], spec["tau"], hold=spec.get("hold", "linear"))
    if kind == "pd":
        return torques.PD(spec["q_target"], spec["kp"], spec["kd"], v_target=spec.get("v_target"),
                          tau_ff=spec.get("tau_ff"))
    if kind == "computed_torque":
        return torques.ComputedTorque(spec["t"], spec["q"], spec["v"], spec["a"], spec["kp"], spec["kd"])
    raise ValueError(f"torque.type: unknown torque type {kind!r}")


def simulate_function():
    """``dynamics.simulate`` if this build of the library has it, else None."""
    import dynamics

    fn = getattr(dynamics, "simulate", None)
    if callable(fn):
        return fn
    try:
        from dynamics.simulate import simulate as fn  # the module exists before __init__ exports it
    except ImportError:
        return None
    return fn if callable(fn) else None


def run_simulation(model, job: dict[str, Any]) -> dict[str, Any]:
    simulate = simulate_function()
    if simulate is None:
        raise ValueError("simulate: this build of dynamics has no simulate()")
    torque = build_torque(model, job.get("torque"))
    options = {k: v for k, v in job["options"].items() if v is not None}
    if torque is not None:
        options["torque"] = torque
    # The step budget is the service's, whatever the request says: a runaway adaptive run ends in a clear
    # "max_steps: ..." 422 rather than in the time budget's 504.
    options["max_steps"] = job["limits"]["max_sim_steps"]
    traj = simulate(model, job["q0"], job["v0"], job["duration"], **options)
    out = {name: np.asarray(getattr(traj, name)) for name in ("t", "q", "v", "tau")}
    out["report"] = _finite_report(dict(getattr(traj, "report", {}) or {}))
    return out
