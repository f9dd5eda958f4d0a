"""The server's one door to the ``dynamics`` library, which it imports in the background.

The server must answer ``/v1/health`` the moment it starts, and importing the library takes a fraction of a second
to a second on a busy machine (numpy, lxml, the C++ core's extension module: measured
with ``python -X importtime -c "import dynamics"``). So no module of the server imports
``dynamics`` at its top: they call :func:`lib` where they use it. The server imports the library in a thread
at start (:mod:`service.deps`); a request that needs it earlier waits in its worker thread on Python's import
lock, never on the event loop. Nothing compiles at run time (the core is compiled at install). Attributes are
looked up at each call (``lib().lock_joints``), so a test may replace one with ``monkeypatch``.

Only the public API is used: ``dynamics.*``, ``dynamics.torques``, ``dynamics.parallel.deadline``.
"""

from __future__ import annotations

import importlib
from types import ModuleType

_dynamics: ModuleType | None = None  # set once the import has completed (a module being imported is not)


def lib() -> ModuleType:
    """The ``dynamics`` package: imported on first use (waiting for an import under way in another thread)."""
    global _dynamics
    if _dynamics is None:
        _dynamics = importlib.import_module("dynamics")
    return _dynamics


def parallel() -> ModuleType:
    """``dynamics.parallel``: batches over threads, and the deadline their chunks check."""
    return importlib.import_module("dynamics.parallel")
