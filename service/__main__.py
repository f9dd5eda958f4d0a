"""``python -m service [--host 127.0.0.1] [--port 8000] [--store DIR] [--workers N] [--ray-address ADDR]``: run the HTTP service.

Options are written into the ``DYNAMICS_*`` environment variables before uvicorn starts, so that every worker
process (``--workers N`` starts them from scratch) reads the same settings.

``--warmup`` is kept for build scripts that still run it (the Docker image once did, to fill a JIT's cache): nothing
is compiled at run time any more, so it only checks that the library imports and the bundled robots load, says
so, and exits 0 (refusing it would break those builds for no gain).
"""

from __future__ import annotations

import argparse
import os
import sys

import uvicorn

from .library import lib
from .models import load_model
from .protocol import HeaderTimeoutProtocol
from .settings import Settings, configure_logging
from .store import RobotStore


#: what --help says first (plain text: the module docstring is reST)
DESCRIPTION = ("Run the HTTP service of the dynamics library. Its other settings (limits, API keys, workers) are "
               "DYNAMICS_* environment variables (see the README's table).")


def _parser(prog: str = "python -m service") -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=prog, description=DESCRIPTION)
    p.add_argument("--host", default=os.environ.get("DYNAMICS_HOST", "127.0.0.1"),
                   help="interface to listen on (default 127.0.0.1; 0.0.0.0 in a container)")
    p.add_argument("--port", type=int, default=int(os.environ.get("DYNAMICS_PORT", "8000")))
    p.add_argument("--store", default=None,
                   help="directory of uploaded robots (default $DYNAMICS_STORE or ./store)")
    p.add_argument("--workers", type=int, default=1, help="server processes (default 1)")
    p.add_argument("--log-level", default="info", help="uvicorn's and the service's (default info)")
    p.add_argument("--ray-address", default=None,
                   help="send job parts to this Ray cluster ('auto', 'ray://head:10001'; $DYNAMICS_RAY_ADDRESS)")
    p.add_argument("--warmup", action="store_true",
                   help="obsolete (the service has no warm-up any more): check that the library imports and the bundled "
                        "robots load, and exit")
    return p


def warmup() -> int:
    """``--warmup``: once a JIT's warm-up; now a check that the library imports and the bundled robots load."""
    settings = Settings.from_env()
    store = RobotStore(settings.store_dir, settings.robots_dir)
    robots = store.bundled_ids()
    lib()
    for rid in robots:
        record = store.get(rid)
        load_model(record.urdf, record.floating_base)
    print(f"warmup: obsolete, the service has no warm-up (the library's core is compiled at install); the library imports "
          f"and the {len(robots)} bundled robots load")
    return 0


def main(argv: list[str] | None = None, prog: str = "python -m service") -> int:
    args = _parser(prog).parse_args(argv)
    if args.store:
        os.environ["DYNAMICS_STORE"] = os.path.abspath(args.store)
    elif "DYNAMICS_STORE" not in os.environ:
        os.environ["DYNAMICS_STORE"] = os.path.abspath("store")
    os.environ["DYNAMICS_LOG_LEVEL"] = args.log_level
    if args.ray_address:
        os.environ["DYNAMICS_RAY_ADDRESS"] = args.ray_address
    if args.warmup:
        configure_logging(args.log_level)
        return warmup()
    # Slow clients: request headers within DYNAMICS_READ_TIMEOUT (HeaderTimeoutProtocol) and at most 16 KiB;
    # idle keep-alive connections closed after 5 s.
    uvicorn.run("service.app:create_app", factory=True, host=args.host, port=args.port,
                workers=max(1, args.workers), log_level=args.log_level, access_log=False,
                timeout_graceful_shutdown=5, http=HeaderTimeoutProtocol, timeout_keep_alive=5,
                h11_max_incomplete_event_size=16 * 1024)
    return 0


if __name__ == "__main__":
    sys.exit(main())
