"""The documentation site at ``/guide``, when it has been built (``mkdocs build`` writes it to ``site/``).

The directory is ``$DYNAMICS_GUIDE_DIR``, by default ``site/`` in the checkout the service runs from; without
it nothing is mounted and ``/guide`` is a 404 (an installed wheel ships no site). Swagger UI stays at ``/docs``.
With API keys on, ``/guide`` needs a key like every path but health and readiness.
"""

from __future__ import annotations

import os
from pathlib import Path

from fastapi import FastAPI
from starlette.staticfiles import StaticFiles

PATH = "/guide"
DEFAULT_DIR = Path(__file__).resolve().parents[2] / "site"


def site_dir() -> Path:
    return Path(os.environ.get("DYNAMICS_GUIDE_DIR") or DEFAULT_DIR)


def mount(app: FastAPI) -> None:
    """Serve the built site under ``/guide`` (``index.html`` for a directory), if there is one."""
    site = site_dir()
    if (site / "index.html").is_file():
        app.mount(PATH, StaticFiles(directory=site, html=True), name="guide")
