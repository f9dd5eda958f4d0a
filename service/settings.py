"""Every knob of the service in one place.

Settings come from environment variables (so that ``uvicorn --workers N`` children, which start from scratch,
see the same values) and ``python -m service`` writes its command-line options into those variables before it
starts uvicorn. Defaults are safe for a public deployment on a small machine.
"""

from __future__ import annotations

import logging
import os
import sys
from dataclasses import dataclass, field, fields
from pathlib import Path

ENV_PREFIX = "DYNAMICS_"


def _env(name: str, default: str) -> str:
    return os.environ.get(ENV_PREFIX + name, default)


def bundled_robots_dir() -> Path | None:
    """Where the read-only robots shipped with the project live.

    ``$DYNAMICS_ROBOTS_DIR`` wins (the Docker image sets it); then ``robots/`` data installed next to the
    packages (a wheel built with the robots as package data); then the repository checkout.
    """
    explicit = os.environ.get(ENV_PREFIX + "ROBOTS_DIR")
    if explicit:
        return Path(explicit)
    here = Path(__file__).resolve().parent
    for candidate in (here / "robots", here.parent / "dynamics" / "robots", here.parent / "robots"):
        if candidate.is_dir() and any(candidate.glob("*.urdf")):
            return candidate
    return None


@dataclass(frozen=True)
class Settings:
    """Limits and locations; one instance per process, built by :meth:`from_env`."""

    # Where uploaded robots are kept (one JSON file per robot, written atomically).
    store_dir: Path = Path("store")
    # The read-only robots served under their file stem ('planar_2r.urdf' -> 'planar_2r'); None = none.
    robots_dir: Path | None = None
    # Largest request body in bytes; enforced while reading, before anything is buffered past it.
    max_body_bytes: int = 8 * 1024 * 1024
    # Largest URDF document and deepest XML nesting accepted on upload.
    max_urdf_bytes: int = 4 * 1024 * 1024
    max_xml_depth: int = 64
    # Largest model (velocity coordinates) and largest batch (states per request).
    max_dof: int = 128
    max_batch: int = 200_000
    # Largest answer, estimated before computing (states x numbers per state x bytes per number): .npz answers,
    # and JSON ones (about 24 bytes per float, and the text is built in memory: a smaller limit).
    max_answer_bytes: int = 128 * 1024 * 1024
    max_json_answer_bytes: int = 32 * 1024 * 1024
    # Per API key (or for all uploads without keys): robots stored and bytes of URDF stored.
    max_robots_per_key: int = 1000
    max_store_bytes: int = 256 * 1024 * 1024
    # URDF elements: links and joints (a 100k-link document is refused while it is parsed).
    max_links: int = 1024
    # Seconds a client may take to send its request headers, and between two pieces of its body.
    read_timeout: float = 30.0
    # Simulation limits: integrator steps (duration / dt for fixed-step integrators) and stored samples.
    max_sim_steps: int = 1_000_000
    max_samples: int = 100_000
    # Wall-time budget of one request's numeric work, seconds. Past it the work stops and the answer is 504.
    time_budget: float = 10.0
    # Compiled models kept in memory per process (least recently used are dropped first).
    cache_size: int = 64
    # Threads running batched dynamics calls, and worker processes running simulations.
    compute_threads: int = field(default_factory=lambda: max(1, min(4, os.cpu_count() or 1)))
    # 0 turns simulation off.
    sim_workers: int = field(default_factory=lambda: max(1, min(2, os.cpu_count() or 1)))
    # API keys; empty = no authentication.
    api_keys: tuple[str, ...] = ()
    # Level of the service's own log (logger "service", on stderr).
    log_level: str = "info"
    # -- jobs (POST /v1/jobs; service.jobs) ----------------------------------------------------------------------
    # Processes running jobs (each job's parts spread over the library's threads, or over Ray); 0 turns jobs off.
    job_workers: int = 1
    # A Ray cluster for job parts ("auto", "ray://head:10001"); empty = the local pool only.
    ray_address: str = ""
    # Largest job input (the request body, JSON or .npz) and largest result (estimated before the job runs).
    max_job_input_bytes: int = 256 * 1024 * 1024
    max_job_result_bytes: int = 2 * 1024 * 1024 * 1024
    # Jobs queued or running at once per API key (429 past it).
    max_jobs_per_key: int = 4
    # Disk kept for one key's job inputs and results (507 past it).
    job_quota_bytes: int = 4 * 1024 * 1024 * 1024
    # Seconds a finished job (its record and result) is kept after it ended.
    job_expiry: float = 7 * 24 * 3600.0
    # Starts of one job (the first and the resumptions after a server restart or a dead worker) before it fails.
    job_attempts: int = 2
    # Target seconds of work per part (a part's result is kept on disk: a restart resumes after the last one).
    job_part_seconds: float = 2.0
    # Results up to this size are answered as JSON when the caller accepts it; larger ones only as .npz.
    job_json_bytes: int = 1024 * 1024
    # -- sessions (the WebSocket /v1/sessions: a simulator stepped by the client; service.sessions) ------------
    # Connections to /v1/sessions open at once per API key (or for all callers without keys); 429 past it.
    max_sessions_per_key: int = 8
    # Seconds a session may wait for its next message before the server closes it (and frees its simulator).
    session_idle_timeout: float = 300.0
    # Largest session, in bytes of the simulator's arrays and workspaces as estimated before it is built.
    max_session_bytes: int = 256 * 1024 * 1024

    @classmethod
    def from_env(cls) -> "Settings":
        defaults = cls()
        keys = tuple(k.strip() for k in _env("API_KEYS", "").split(",") if k.strip())
        robots = bundled_robots_dir()
        return cls(
            store_dir=Path(_env("STORE", str(defaults.store_dir))),
            robots_dir=robots,
            max_body_bytes=int(_env("MAX_BODY_BYTES", str(defaults.max_body_bytes))),
            max_urdf_bytes=int(_env("MAX_URDF_BYTES", str(defaults.max_urdf_bytes))),
            max_xml_depth=int(_env("MAX_XML_DEPTH", str(defaults.max_xml_depth))),
            max_dof=int(_env("MAX_DOF", str(defaults.max_dof))),
            max_batch=int(_env("MAX_BATCH", str(defaults.max_batch))),
            max_answer_bytes=int(_env("MAX_ANSWER_BYTES", str(defaults.max_answer_bytes))),
            max_json_answer_bytes=int(_env("MAX_JSON_ANSWER_BYTES", str(defaults.max_json_answer_bytes))),
            max_robots_per_key=int(_env("MAX_ROBOTS_PER_KEY", str(defaults.max_robots_per_key))),
            max_store_bytes=int(_env("MAX_STORE_BYTES", str(defaults.max_store_bytes))),
            max_links=int(_env("MAX_LINKS", str(defaults.max_links))),
            read_timeout=float(_env("READ_TIMEOUT", str(defaults.read_timeout))),
            max_sim_steps=int(_env("MAX_SIM_STEPS", str(defaults.max_sim_steps))),
            max_samples=int(_env("MAX_SAMPLES", str(defaults.max_samples))),
            time_budget=float(_env("TIME_BUDGET", str(defaults.time_budget))),
            cache_size=int(_env("CACHE_SIZE", str(defaults.cache_size))),
            compute_threads=int(_env("COMPUTE_THREADS", str(defaults.compute_threads))),
            sim_workers=int(_env("SIM_WORKERS", str(defaults.sim_workers))),
            api_keys=keys,
            log_level=_env("LOG_LEVEL", defaults.log_level),
            **_named_settings(defaults, JOB_SETTINGS + SESSION_SETTINGS),
        )

    @staticmethod
    def env_names() -> dict[str, str]:
        """Field name -> environment variable, for the docs and ``--help``."""
        special = {"store_dir": "STORE", "robots_dir": "ROBOTS_DIR"}
        return {f.name: ENV_PREFIX + special.get(f.name, f.name.upper()) for f in fields(Settings)}


#: the fields read by :func:`_named_settings` (the jobs', and the sessions')
JOB_SETTINGS = ("job_workers", "ray_address", "max_job_input_bytes", "max_job_result_bytes", "max_jobs_per_key",
                "job_quota_bytes", "job_expiry", "job_attempts", "job_part_seconds", "job_json_bytes")
SESSION_SETTINGS = ("max_sessions_per_key", "session_idle_timeout", "max_session_bytes")


def _named_settings(defaults: Settings, names: tuple[str, ...]) -> dict:
    """Fields from ``DYNAMICS_<FIELD>`` (``DYNAMICS_RAY_ADDRESS``, ``DYNAMICS_MAX_SESSIONS_PER_KEY``, ...), typed
    like their defaults."""
    return {name: type(getattr(defaults, name))(_env(name.upper(), str(getattr(defaults, name)))) for name in names}


def configure_logging(level: str) -> None:
    """The service's log (logger ``service``) on stderr at ``level``, beside uvicorn's own; idempotent."""
    logger = logging.getLogger("service")
    if not logger.handlers:
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        logger.addHandler(handler)
    number = logging.getLevelName(level.upper())  # uvicorn's "trace" is no logging level: debug then
    logger.setLevel(number if isinstance(number, int) else logging.DEBUG)


class _Once(logging.Filter):
    """Lets each distinct message through once (a warning repeated by every job of a worker)."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if message in self.seen:
            return False
        self.seen.add(message)
        return True


def configure_worker_logging() -> None:
    """A simulation worker's log: the library's messages (its warnings) on stderr with a time and the worker's
    pid, each once; without it Python's last-resort handler prints them bare."""
    logger = logging.getLogger("dynamics")
    if not logger.handlers:
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s worker %(process)d %(name)s: %(message)s"))
        handler.addFilter(_Once())
        logger.addHandler(handler)
