"""The service run inside ``dynamics view``: the app on a loopback port, in a thread of the command's process.

:func:`local_service` starts it (uvicorn in a background thread: the command's main thread stays free for
Ctrl-C), waits until it listens, and stops it on exit. The trajectory handed over (``--trajectory``) is kept in
``app.state.inspect_trajectory`` and served at ``/inspect/trajectory`` (:mod:`service.routes.inspect`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import socket
import tempfile
import threading
import time
from pathlib import Path
from typing import Iterator, Optional

import uvicorn

from .app import create_app
from .settings import Settings


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def local_service(port: int = 0, store: Optional[str] = None, trajectory: Optional[bytes] = None,
                  timeout: float = 60.0) -> Iterator[str]:
    """The service on 127.0.0.1:``port`` (0: a free one) with the environment's settings and ``store`` (default: a
    temporary directory, removed on exit); yields its base URL once it listens."""
    with contextlib.ExitStack() as stack:
        directory = Path(store) if store else Path(stack.enter_context(tempfile.TemporaryDirectory()))
        app = create_app(dataclasses.replace(Settings.from_env(), store_dir=directory))
        app.state.inspect_trajectory = trajectory
        port = port or free_port()
        server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning",
                                               access_log=False))
        thread = threading.Thread(target=server.run, name="dynamics-view", daemon=True)
        thread.start()
        deadline = time.monotonic() + timeout
        while not server.started:
            if not thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError(f"the service did not start on port {port}")
            time.sleep(0.05)
        try:
            yield f"http://127.0.0.1:{port}"
        finally:
            server.should_exit = True
            thread.join(30)
