"""The simulation worker process: ``python -m service.sim.worker FD`` (started by :mod:`service.sim.pool`).

It compiles the simulation kernels first (:func:`warm_up`: a tiny simulation per integrator and problem type),
says "ready", compiles the operational-space and computed-torque sources in a background thread
(:class:`LateWarmup`), then reads :class:`~service.sim.job.Job` records from the connection on file descriptor
FD, runs ``dynamics.simulate`` and sends an :class:`~service.sim.job.Outcome` back. Models are cached per worker
by robot id and locked set, as in the server. A library error becomes ``input_error`` (the server answers 422
naming the field); the process only ends when its connection closes or the server kills it.

The HTTP torque spec (``{"type": "zero" | "constant" | "table" | "pd" | "computed_torque" |
"operational_space", ...}``) is turned into
the library's torque objects here (:func:`build_torque`), so that the server needs no numeric code for it.
"""

from __future__ import annotations

import math
import sys
import threading
import time
import traceback
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from ..errors import InvalidInput
from ..library import lib
from ..models import ModelCache, load_model, reduce_model
from ..warmup import WARMUP_URDF
from .job import Job, Outcome

#: the integrators besides the default ('auto') whose loops the warm-up compiles (schemas.SimulateRequest's)
WARM_INTEGRATORS = ("rk4", "dop853", "rk45", "radau", "euler")


def build_torque(spec: dict[str, Any] | None):
    """The HTTP torque spec -> the ``torque=`` argument of dynamics.simulate (see dynamics.torques).

    The library checks shapes and signs and names the field ("torque.kp: expected shape (6,), got (5,)").
    """
    torques = lib().torques
    kind = None if spec is None else spec["type"]
    if kind is None or kind == "zero":
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
    if kind == "operational_space":
        return _operational_space(torques, spec)
    raise InvalidInput(f"torque.type: unknown torque type {kind!r}", "torque.type")


def _operational_space(torques, spec: dict[str, Any]):
    """{"reference": {...}} tracks a path (OperationalSpace), {"position": ...} holds a pose (Target)."""
    kw = {k: spec.get(k) for k in ("posture", "posture_kp", "posture_kd", "rows", "damping")}
    ref = spec.get("reference")
    if (ref is None) == (spec.get("position") is None):
        raise InvalidInput("torque.reference: give either reference (a path) or position (a fixed target)",
                           "torque.reference")
    if ref is None:
        return torques.Target(spec["frame"], spec["position"], spec.get("orientation"), kp=spec["kp"],
                              kd=spec["kd"], **kw)
    if spec.get("orientation") is not None:
        raise InvalidInput("torque.orientation: with a reference, give reference.orientation", "torque.orientation")
    return torques.OperationalSpace(spec["frame"], torques.TaskReference(**ref), spec["kp"], spec["kd"], **kw)


def finite_report(obj: Any) -> Any:
    """JSON has no NaN or infinity: such numbers in the report become null."""
    if isinstance(obj, dict):
        return {str(k): finite_report(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_report(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return finite_report(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    return str(obj)


def simulate(model, job: Job) -> dict[str, Any] | Outcome:
    """The trajectory of ``job``, or (a torque source still compiling past the job's deadline) the Outcome
    that says so."""
    options = dict(job.options)
    torque = build_torque(job.torque)
    if job.torque is not None and job.torque["type"] in LATER.kinds and not LATER.done.is_set():
        lib().torques.make_source(model, torque)  # a bad spec is answered (422) at once, not after the wait
        if not LATER.wait(job.deadline):
            return LATER.unavailable()
    if torque is not None:
        options["torque"] = torque
    # The step budget is the service's: a runaway adaptive run ends in a clear "max_steps: ..." 422 rather than
    # in the time budget's 504.
    traj = lib().simulate(model, job.q0, job.v0, job.duration, max_steps=job.max_steps, **options)
    out = {name: np.asarray(getattr(traj, name)) for name in ("t", "q", "v", "tau")}
    if traj.lam is not None:
        out["lambda"] = np.asarray(traj.lam)
    out["report"] = finite_report(dict(traj.report or {}))
    return out


def handle(job: Job, cache: ModelCache) -> Outcome:
    try:
        model = cache.get_or_load((job.robot_id, ()), lambda: load_model(job.urdf, job.floating_base))
        if job.locked:
            full = model
            model = cache.get_or_load((job.robot_id, job.locked), lambda: reduce_model(full, job.locked))
        out = simulate(model, job)
        return out if isinstance(out, Outcome) else Outcome(trajectory=out)
    except InvalidInput as e:  # our own reading of the request (a URDF refused, an unknown torque type)
        return Outcome(input_error=e.detail)
    except ValueError as e:  # the library's InputError, URDFError, DynamicsError: the message names the field
        return Outcome(input_error=str(e))
    except Exception as e:  # noqa: BLE001 - reported to the server, which answers 500
        traceback.print_exc()
        return Outcome(error=f"{type(e).__name__}: {e}")


def warm_up() -> None:
    """One tiny simulation per integrator the service accepts, and per torque kind with the default one: numba
    compiles each method's integration loop (or loads it from its cache) before the worker says "ready", so that
    no request's time budget runs into a compilation (each method is compiled on its own since the simulation
    split: a request naming dop853 would otherwise compile it inside its budget)."""
    model = load_model(WARMUP_URDF, floating_base=False)
    q0, v0 = np.array([0.1]), np.zeros(1)
    for spec in ({"type": "zero"}, {"type": "pd", "q_target": np.zeros(1), "kp": 1.0, "kd": 1.0}):
        lib().simulate(model, q0, v0, 0.01, torque=build_torque(spec))
    for integrator in WARM_INTEGRATORS:
        lib().simulate(model, q0, v0, 0.01, integrator=integrator, dt=0.005)
    # a closed loop (the bundled four-bar): constrained models integrate another problem type, compiled once
    dyn = lib()
    four_bar = dyn.load_urdf(dyn.robots.path("four_bar"))
    q = dyn.assemble(four_bar, [0.3, 0.5, 1.5], fixed={"theta1": 0.3})
    dyn.simulate(four_bar, q, np.zeros(four_bar.nv), 0.01)


def warm_up_later() -> None:
    """The simulations :class:`LateWarmup` compiles (``python -m service --warmup`` runs it too)."""
    model = load_model(WARMUP_URDF, floating_base=False)
    torque = build_torque({"type": "operational_space", "frame": "arm", "position": [0.2, 0.0, -0.4],
                           "kp": 1.0, "kd": 1.0, "rows": [0, 2]})
    lib().simulate(model, np.array([0.1]), np.zeros(1), 0.01, torque=torque)
    t = np.array([0.0, 0.01])
    torque = build_torque({"type": "computed_torque", "t": t, "q": np.zeros((2, 1)), "v": np.zeros((2, 1)),
                           "a": np.zeros((2, 1)), "kp": 1.0, "kd": 1.0})
    lib().simulate(model, np.array([0.1]), np.zeros(1), 0.01, torque=torque)


def warm_up_rest() -> None:
    """What a first request of another kind would otherwise compile inside its time budget, compiled after the
    late warm-up (each is a few seconds from an empty cache): the constant and table torques (a source compiles
    only its own kind), a floating-base model (the free joint's chart), and auto's first switch to radau (a stiff
    PD: radau is compiled only when auto first switches to it)."""
    model = load_model(WARMUP_URDF, floating_base=False)
    q0, v0 = np.array([0.1]), np.zeros(1)
    for spec in ({"type": "constant", "tau": [0.1]}, {"type": "table", "t": [0.0, 1.0], "tau": [[0.0], [0.1]]},
                 {"type": "pd", "q_target": np.zeros(1), "kp": 1e4, "kd": 1e3}):
        lib().simulate(model, q0, v0, 0.05, torque=build_torque(spec))
    floating = load_model(WARMUP_URDF, floating_base=True)
    lib().simulate(floating, floating.neutral(), np.zeros(floating.nv), 0.01)


class LateWarmup:
    """The simulations compiled after the worker says "ready", in a background thread: the operational-space and
    computed-torque sources are problem types of their own (their controller, their RNEA are compiled only for
    them), so the other requests need not wait for them.  A request that needs them waits until its deadline
    (less a second to answer), then is told how long they should still take."""

    #: the torque types it compiles
    kinds = ("operational_space", "computed_torque")
    #: seconds it takes from an empty numba cache (CPU seconds on a loaded 2-core machine); from the cache well
    #: under one
    SECONDS = 45.0

    def __init__(self) -> None:
        self.done = threading.Event()
        self.started = time.monotonic()

    def start(self) -> None:
        self.started = time.monotonic()
        threading.Thread(target=self._run, daemon=True, name="late-warm-up").start()

    def _run(self) -> None:
        try:
            warm_up_later()
        except Exception:  # noqa: BLE001 - the requests that need it compile it themselves and report
            traceback.print_exc()
        finally:
            self.done.set()
        try:  # no request waits for these: one that comes first compiles its own part
            warm_up_rest()
        except Exception:  # noqa: BLE001
            traceback.print_exc()

    def wait(self, deadline: float) -> bool:
        """Whether it is done, waiting for it until ``deadline`` (time.monotonic) less a second."""
        return self.done.is_set() or self.done.wait(max(0.0, deadline - time.monotonic() - 1.0))

    def unavailable(self) -> Outcome:
        elapsed = time.monotonic() - self.started
        left = max(1.0, self.SECONDS - elapsed)
        return Outcome(unavailable=f"this worker is still compiling the simulation kernels of the operational-space "
                                  f"and computed-torque sources (for {elapsed:.0f} s, about {left:.0f} s left, once "
                                  "after the service starts with an empty cache); retry then", retry_after=left)


LATER = LateWarmup()


def main(fd: int) -> None:
    conn = Connection(fd)
    cache = ModelCache(16)
    for attempt in range(2):  # before "ready": no request's time budget ever runs into a compilation
        try:
            warm_up()
            break
        except Exception:  # noqa: BLE001 - once more (e.g. a cache file being written by another process),
            traceback.print_exc()  # then the first job reports the real problem
    try:
        conn.send("ready")
    except OSError:
        return
    LATER.start()
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        conn.send(handle(job, cache))


if __name__ == "__main__":
    main(int(sys.argv[1]))
