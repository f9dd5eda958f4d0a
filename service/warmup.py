"""The warm-up at start: what is compiled, its progress in the log, and how long it should still take.

On an empty numba cache the first calls of the library compile for a long time (minutes for the simulation
loop). So a new server process answers ``/v1/health`` at once and, in a background thread, goes through:

1. importing the library (:mod:`service.library`);
2. compiling the dynamics kernels: every operation once on a tiny robot, in this process;
3. compiling the simulation kernels: the worker processes compile from the start (each runs a tiny simulation
   before it says "ready"); this stage waits for the first of them.

Each stage is logged (logger ``service``, INFO, to stderr) when it starts and ends, with its seconds, plus a
"still ..." line every :data:`HEARTBEAT` seconds. Until the end ``/v1/ready`` answers 503, and a simulate
request waits for the workers within its time budget, then gets a 503 whose message comes from
:meth:`Warmup.status`: how long the warm-up has been running and about how long it should still take. That
estimate is the previous start's duration, recorded next to the robot store; the first start has only a
guess (:data:`FIRST_START_GUESS`).
"""

from __future__ import annotations

import json
import logging
import math
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional

from .store import atomic_write

log = logging.getLogger("service")

#: seconds between two "still ..." lines of a long stage
HEARTBEAT = 15.0
#: the whole warm-up's duration when no earlier start is recorded (an empty numba cache takes about this long)
FIRST_START_GUESS = 120.0

#: the robot every warm-up compiles on: one revolute joint below a base with mass (so that it may also float);
#: the kernels' types do not depend on the robot
WARMUP_URDF = b"""<robot name="warmup">
  <link name="base"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="hinge" type="continuous"><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/></joint>
</robot>"""


@dataclass(frozen=True)
class Stage:
    name: str                    # "compiling dynamics kernels"
    run: Callable[[], object]    # blocks until the stage is done


class Warmup:
    """Runs the stages once, in order, and answers how far they are."""

    def __init__(self, history: Optional[Path] = None):
        """``history``: a file holding the last warm-up's duration, read now and written at the end (None: no
        record, as for the one-off ``python -m service --warmup``)."""
        self.history = history
        self.expected = _read_seconds(history)  # the last start's duration, None if unknown
        self.stages: list[Stage] = []
        self.current = 0  # index of the stage under way
        self.started = time.monotonic()
        self.seconds: Optional[float] = None  # the whole warm-up's duration, once done
        self.failures: list[dict[str, str]] = []  # [{"stage": name, "error": one line}] of the stages that failed
        self._done = threading.Event()

    def start(self, stages: list[Stage]) -> None:
        """Run ``stages`` in a background thread (the server's start)."""
        threading.Thread(target=self.run, args=(stages,), daemon=True, name="warm-up").start()

    def run(self, stages: list[Stage]) -> None:
        """Run ``stages`` in this thread, logging each; a failed stage is logged and the next one runs."""
        self.stages, self.started = stages, time.monotonic()
        threading.Thread(target=self._heartbeat, daemon=True, name="warm-up-log").start()
        for i, stage in enumerate(stages):
            self.current = i
            t0 = time.monotonic()
            log.info("warm-up: %s (%s) ...", stage.name, self._stage_number())
            try:
                stage.run()
            except Exception as e:  # noqa: BLE001 - shown in /v1/ready; the requests that need it say what is wrong
                log.exception("warm-up: %s (%s) failed after %.1f s", stage.name, self._stage_number(),
                              time.monotonic() - t0)
                self.failures.append({"stage": stage.name, "error": f"{type(e).__name__}: {e}"})
                continue
            log.info("warm-up: %s (%s) done in %.1f s", stage.name, self._stage_number(), time.monotonic() - t0)
        self.seconds = time.monotonic() - self.started
        if self.history is not None:  # before ready: a caller that waited for ready finds the store settled
            try:
                atomic_write(self.history, json.dumps({"seconds": self.seconds}).encode())
            except OSError as e:
                log.warning("warm-up: could not record its duration in %s: %s", self.history, e)
        self._done.set()
        log.info("warm-up: ready after %.1f s", self.seconds)

    def _heartbeat(self) -> None:
        while not self._done.wait(HEARTBEAT):
            log.info("warm-up: still %s (%s), %.0f s since start", self.stages[self.current].name,
                     self._stage_number(), self.elapsed())

    def _stage_number(self) -> str:
        return f"stage {self.current + 1}/{len(self.stages)}"

    # -- progress ----------------------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self._done.is_set()

    def elapsed(self) -> float:
        return time.monotonic() - self.started if self.seconds is None else self.seconds

    def remaining(self) -> float:
        """Seconds the warm-up should still take (0 once done): the last start's duration less the time spent."""
        if self.done:
            return 0.0
        return max(0.0, (self.expected or FIRST_START_GUESS) - self.elapsed())

    def status(self) -> str:
        """One sentence for a 503: the stage, the seconds so far, the seconds left and where that estimate comes
        from."""
        if self.done:
            return f"the service finished warming up in {_seconds(self.seconds)} s"
        stage = f"{self.stages[self.current].name} ({self._stage_number()})" if self.stages else "starting"
        basis = (f"the last start took {_seconds(self.expected)} s" if self.expected is not None else
                 "a guess: no earlier start is recorded here")
        so_far = f"the service has been warming up for {_seconds(self.elapsed())} s, now {stage}"
        left = self.remaining()
        if left <= 0:
            return f"{so_far}; this is longer than expected ({basis}), it should be ready shortly"
        return f"{so_far}; it should be ready in about {_seconds(left)} s ({basis})"

    def retry_after(self) -> int:
        """Seconds for a Retry-After header: the estimate, within [1, 60], or 5 once past it."""
        left = self.remaining()
        return 5 if left <= 0 else int(min(60, max(1, math.ceil(left))))


def _seconds(x: float) -> str:
    return f"{x:.1f}" if x < 10 else f"{x:.0f}"


def _read_seconds(path: Optional[Path]) -> Optional[float]:
    try:
        seconds = float(json.loads(path.read_text())["seconds"]) if path is not None else None
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return seconds if seconds is not None and math.isfinite(seconds) and seconds > 0 else None
