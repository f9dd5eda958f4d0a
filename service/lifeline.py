"""Child processes die with the server that started them (simulation workers, job workers).

A SIGKILLed server runs no clean-up, and its children would live on, re-parented to PID 1 (each holds a few
hundred MB and may be in a long computation). Two guards, both in the child: Linux's parent-death signal
(``prctl(PR_SET_PDEATHSIG, SIGKILL)``: the kernel kills the child when the thread that started it ends, so the
server starts its children from threads that live as long as it does), and, where there is no prctl, a thread
that exits when the parent pid changes. Either way a child that finds its parent already gone exits at once.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading

#: seconds between two looks at the parent pid (the fallback's delay)
WATCH_SECONDS = 0.5
_PR_SET_PDEATHSIG = 1


def _parent_death_signal() -> bool:
    """Ask the kernel for SIGKILL when our parent dies; whether it could be asked."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _watch(parent: int) -> None:
    stop = threading.Event()
    while not stop.wait(WATCH_SECONDS):
        if os.getppid() != parent:
            os._exit(1)


def bind_to_parent(parent: int) -> None:
    """Exit when process ``parent`` (the server, our parent) dies. Call first thing in a child."""
    armed = _parent_death_signal()
    if os.getppid() != parent:  # it died before the signal was armed
        os._exit(1)
    if not armed:
        threading.Thread(target=_watch, args=(parent,), daemon=True, name="parent-watch").start()
