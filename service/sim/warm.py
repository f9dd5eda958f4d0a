"""What a simulation worker compiles: :func:`warm_up` before it says "ready" (a tiny simulation per integrator
and problem type), then, in a background thread (:class:`LateWarmup`), the operational-space and computed-torque
sources (:func:`warm_up_later`), a simulation with contact (:func:`warm_up_contact`) and the rest
(:func:`warm_up_rest`). ``python -m service --warmup`` (the Docker build step) runs the same four in one process,
so that a failure here fails the build.
"""

from __future__ import annotations

import threading
import time
import traceback
from typing import Callable, Optional

import numpy as np

from .. import contact as contacts
from .. import torque as torques
from ..library import lib
from ..models import load_model
from ..warmup import WARMUP_URDF
from .job import Outcome

#: the integrators besides the default ('auto') whose loops the warm-up compiles (schemas.SimulateRequest's)
WARM_INTEGRATORS = ("rk4", "dop853", "rk45", "radau", "euler")


def warm_up() -> None:
    """One tiny simulation per integrator the service accepts, and per torque kind with the default one: numba
    compiles each method's integration loop (or loads it from its cache) before the worker says "ready", so that
    no request's time budget runs into a compilation (each method is compiled on its own since the simulation
    split: a request naming dop853 would otherwise compile it inside its budget)."""
    model = load_model(WARMUP_URDF, floating_base=False)
    q0, v0 = np.array([0.1]), np.zeros(1)
    for spec in ({"type": "zero"}, {"type": "pd", "q_target": np.zeros(1), "kp": 1.0, "kd": 1.0}):
        lib().simulate(model, q0, v0, 0.01, torque=torques.build(spec))
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
    # the frame 'arm' sits on the hinge's axis, so its position rows of J are zero: damping keeps the task
    # regular (without it the run stops at t = 0 as singular, with a warning in every worker's log)
    torque = torques.build({"type": "operational_space", "frame": "arm", "position": [0.2, 0.0, -0.4],
                           "kp": 1.0, "kd": 1.0, "rows": [0, 2], "damping": 0.01})
    lib().simulate(model, np.array([0.1]), np.zeros(1), 0.01, torque=torque)
    t = np.array([0.0, 0.01])
    torque = torques.build({"type": "computed_torque", "t": t, "q": np.zeros((2, 1)), "v": np.zeros((2, 1)),
                           "a": np.zeros((2, 1)), "kp": 1.0, "kd": 1.0})
    lib().simulate(model, np.array([0.1]), np.zeros(1), 0.01, torque=torque)


def warm_up_contact() -> None:
    """A simulation with contact: its problem type (the narrow phase, the force law, the contact quadrature) is
    compiled only for runs with contact, two to three minutes from an empty cache (both of auto's phases). A
    floating body with a sphere on the default ground, as most contact requests are (a free base with feet)."""
    floating, q0, contact = _contact_scene()
    lib().simulate(floating, q0, np.zeros(floating.nv), 0.2, contact=contact)


def _contact_scene():
    """The warm-up's floating body with a sphere at the end of its arm, 0.05 m above the default ground."""
    floating = load_model(WARMUP_URDF, floating_base=True)
    q0 = floating.neutral()
    q0[2] = 0.6  # the sphere on the arm's end (0.5 m below the base) 0.05 m from touching
    contact = contacts.build({"geometries": [{"type": "sphere", "frame": "arm", "radius": 0.05,
                                              "offset": [0.0, 0.0, -0.5]}]})
    return floating, q0, contact


def warm_up_rest() -> None:
    """What a first request of another kind would otherwise compile inside its time budget, compiled after the
    late warm-up (each is a few seconds from an empty cache): the constant and table torques (a source compiles
    only its own kind), a floating-base model (the free joint's chart), and auto's first switch to radau (a stiff
    PD: radau is compiled only when auto first switches to it), and contact under a PD controller (a robot
    standing on its feet: a problem type of its own, a few minutes from an empty cache)."""
    model = load_model(WARMUP_URDF, floating_base=False)
    q0, v0 = np.array([0.1]), np.zeros(1)
    for spec in ({"type": "constant", "tau": [0.1]}, {"type": "table", "t": [0.0, 1.0], "tau": [[0.0], [0.1]]},
                 {"type": "pd", "q_target": np.zeros(1), "kp": 1e4, "kd": 1e3}):
        lib().simulate(model, q0, v0, 0.05, torque=torques.build(spec))
    floating = load_model(WARMUP_URDF, floating_base=True)
    lib().simulate(floating, floating.neutral(), np.zeros(floating.nv), 0.01)
    floating, q0, contact = _contact_scene()
    pd = torques.build({"type": "pd", "q_target": q0, "kp": 1.0, "kd": 1.0})
    lib().simulate(floating, q0, np.zeros(floating.nv), 0.2, torque=pd, contact=contact)


def attempt(warm: Callable[[], None], tries: int = 2) -> Optional[str]:
    """Run ``warm`` (once more if it fails: a cache file being written by another process); None, or the last
    failure in one line (its traceback printed to stderr, the worker's log)."""
    error = None
    for _ in range(tries):
        try:
            warm()
            return None
        except Exception as e:  # noqa: BLE001 - reported, and the requests that need it say what is wrong
            traceback.print_exc()
            error = f"{type(e).__name__}: {e}"
    return error


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

    #: seconds the contact kernels take from an empty numba cache (auto's two phases with contact: 92 + 71 s in
    #: a worker of the test suite's servers, 2-core machine)
    CONTACT_SECONDS = 160.0

    def __init__(self) -> None:
        self.done = threading.Event()
        self.contact_done = threading.Event()  # warm_up_contact ended (compiled, or failed: a request compiles)
        self.started = time.monotonic()
        self.error: Optional[str] = None  # why the late warm-up failed (after two attempts), None if it did not

    def start(self, report: Callable[[str, Optional[str]], None] = lambda stage, error: None) -> None:
        """Compile in a background thread; ``report("late", error)`` once the kinds of :attr:`kinds` are compiled
        (None) or could not be (the error in one line: the server shows it in ``/v1/ready``), then
        ``report("rest", error)`` after :func:`warm_up_rest`."""
        self.started = time.monotonic()
        threading.Thread(target=self._run, args=(report,), daemon=True, name="late-warm-up").start()

    def _run(self, report: Callable[[str, Optional[str]], None]) -> None:
        try:
            self.error = attempt(warm_up_later)
        finally:
            self.done.set()
        report("late", self.error)
        try:
            error = attempt(warm_up_contact)
        finally:
            self.contact_done.set()
        report("contact", error)
        # no request waits for these: one that comes first compiles its own part (and, past its budget, is told
        # that the worker was still compiling: service.compute)
        report("rest", attempt(warm_up_rest))

    def wait(self, deadline: float) -> bool:
        """Whether it is done, waiting for it until ``deadline`` (time.monotonic) less a second."""
        return self.done.is_set() or self.done.wait(max(0.0, deadline - time.monotonic() - 1.0))

    def wait_contact(self, deadline: float) -> bool:
        """Whether the contact kernels are compiled, waiting for them until ``deadline`` less a second."""
        return self.contact_done.is_set() or self.contact_done.wait(max(0.0, deadline - time.monotonic() - 1.0))

    def contact_unavailable(self) -> Outcome:
        elapsed = time.monotonic() - self.started
        left = max(1.0, self.SECONDS + self.CONTACT_SECONDS - elapsed)
        return Outcome(unavailable=f"this worker is still compiling the contact simulation kernels (for {elapsed:.0f} "
                                  f"s since its start, about {left:.0f} s left, once after the service starts with "
                                  "an empty cache); retry then", retry_after=left)

    def unavailable(self) -> Outcome:
        elapsed = time.monotonic() - self.started
        left = max(1.0, self.SECONDS - elapsed)
        return Outcome(unavailable=f"this worker is still compiling the simulation kernels of the operational-space "
                                  f"and computed-torque sources (for {elapsed:.0f} s, about {left:.0f} s left, once "
                                  "after the service starts with an empty cache); retry then", retry_after=left)


LATER = LateWarmup()
