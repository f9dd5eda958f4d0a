"""``python -m service [--host 127.0.0.1] [--port 8000] [--store DIR] [--workers N]``: run the HTTP service.

Options are written into the ``DYNAMICS_*`` environment variables before uvicorn starts, so that every worker
process (``--workers N`` starts them from scratch) reads the same settings. ``--warmup`` compiles the numeric
kernels on the bundled robots (and fills numba's on-disk cache, as the Docker image does at build time) and
exits.
"""

from __future__ import annotations

import argparse
import os
import sys


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m service", description=__doc__.split("\n\n")[0])
    p.add_argument("--host", default=os.environ.get("DYNAMICS_HOST", "127.0.0.1"),
                   help="interface to listen on (default 127.0.0.1; 0.0.0.0 in a container)")
    p.add_argument("--port", type=int, default=int(os.environ.get("DYNAMICS_PORT", "8000")))
    p.add_argument("--store", default=None,
                   help="directory of uploaded robots (default $DYNAMICS_STORE or ./store)")
    p.add_argument("--workers", type=int, default=1, help="server processes (default 1)")
    p.add_argument("--log-level", default="info")
    p.add_argument("--warmup", action="store_true", help="compile the kernels on the bundled robots and exit")
    return p


def warmup() -> int:
    """Call every endpoint's library function once per bundled robot (numba compiles and caches them)."""
    import numpy as np

    from .simjob import simulate_function
    from .settings import Settings
    from .store import RobotStore
    from .compute import load_model, operations

    settings = Settings.from_env()
    store = RobotStore(settings.store_dir, settings.robots_dir)
    done = 0
    for rid in store.bundled_ids():
        model = load_model(store.get(rid))
        q = np.tile(model.neutral(), (2, 1))
        v = np.zeros((2, model.nv))
        for op in operations().values():
            args = {"q": q, "v": v, "a": v, "tau": v}
            op.func(model, *[args[s] for s in op.states])
            op.func(model, *[args[s][0] for s in op.states])
        simulate = simulate_function() if settings.sim_workers > 0 else None  # no simulation, no warming
        if simulate is not None:
            try:
                simulate(model, q[0], v[0], 0.01, error_estimate="none")
            except Exception as e:  # noqa: BLE001 - warming is best effort
                print(f"warmup: simulate on {rid} failed: {e}", file=sys.stderr)
        done += 1
    print(f"warmup: compiled kernels on {done} bundled robots")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.store:
        os.environ["DYNAMICS_STORE"] = os.path.abspath(args.store)
    elif "DYNAMICS_STORE" not in os.environ:
        os.environ["DYNAMICS_STORE"] = os.path.abspath("store")
    if args.warmup:
        return warmup()

    import uvicorn

    uvicorn.run("service.app:create_app", factory=True, host=args.host, port=args.port,
                workers=max(1, args.workers), log_level=args.log_level, access_log=False,
                timeout_graceful_shutdown=5)
    return 0


if __name__ == "__main__":
    sys.exit(main())
