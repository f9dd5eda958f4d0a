"""The inspector: ``GET /inspect`` and ``/inspect/{robot}``, a page that draws a robot and plays trajectories.

Static files only: the page (``service/inspect/``: HTML, script, style, no build step) and its 3D library, the
meshcat viewer bundle (three.js inside) served from the installed ``meshcat`` package (``pip install
'dynamics[inspect]'``), so that nothing is fetched from the internet. The page calls the API like any client
(``/v1/robots/{id}/inspect``, ``kinematics``, ``gravity-torques``, ``simulate``, ``/v1/jobs``), with the API
key the user types kept in the page's memory only.

The routes are added after every API route, so an API request never reaches them (Starlette tries routes in
order), and the files are read only when asked for. The paths are open without a key (:mod:`service.auth`):
they hold no data, only the code of the page. ``/inspect/trajectory`` serves the trajectory ``dynamics view
--trajectory`` handed to the server it started (``app.state.inspect_trajectory``), 404 otherwise; being
data, it needs a key when keys are on.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Optional

from fastapi import APIRouter, Request
from starlette.responses import FileResponse, Response

from ..codec import JSON
from ..errors import NotFound

PREFIX = "/inspect"
TRAJECTORY = PREFIX + "/trajectory"  # (data: keyed like the API when keys are on)
PAGE_DIR = Path(__file__).resolve().parents[1] / "inspect"
#: the page's own files, by the name the page asks for
PAGE_FILES = {"inspector.js": "text/javascript", "plots.js": "text/javascript", "inspector.css": "text/css"}
#: the viewer bundle inside the meshcat wheel
VIEWER = ("viewer", "dist", "main.min.js")

router = APIRouter(include_in_schema=False)


def viewer_file() -> Optional[Path]:
    """meshcat's viewer bundle, located without importing meshcat (it imports IPython and zmq); None if absent."""
    spec = importlib.util.find_spec("meshcat")
    if spec is None or not spec.submodule_search_locations:
        return None
    path = Path(next(iter(spec.submodule_search_locations)), *VIEWER)
    return path if path.is_file() else None


#: the page's Content-Security-Policy: users type their API key here. Scripts only from this server (no inline
#: script, no eval: the page and meshcat's bundle need neither), never framed by another site (clickjacking),
#: requests only to this server, no plugins, no <base>, no form sent anywhere (the page's forms are handled by
#: its script). Styles may be inline (meshcat's dat.gui and the plots insert <style> elements and style
#: attributes), images and workers may come from data: and blob: URLs (three.js makes textures and workers so).
PAGE_POLICY = ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; "
               "worker-src 'self' blob:; connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'none'; "
               "frame-ancestors 'none'")
PAGE_HEADERS = {"Cache-Control": "no-cache", "Referrer-Policy": "no-referrer", "Content-Security-Policy": PAGE_POLICY,
                "X-Frame-Options": "DENY"}  # (X-Frame-Options: browsers older than frame-ancestors)


def _page() -> FileResponse:
    return FileResponse(PAGE_DIR / "index.html", media_type="text/html", headers=PAGE_HEADERS)


@router.get(PREFIX)
async def page() -> Response:
    return _page()


@router.get(PREFIX + "/static/{name}")
async def static(name: str) -> Response:
    if name not in PAGE_FILES:
        raise NotFound(f"file: no inspector file {name[:64]!r}", "file")
    return FileResponse(PAGE_DIR / name, media_type=PAGE_FILES[name], headers={"Cache-Control": "no-cache"})


@router.get(PREFIX + "/lib/meshcat.js")
async def viewer() -> Response:
    path = viewer_file()
    if path is None:
        raise NotFound("meshcat: the inspector's 3D viewer is not installed; pip install 'dynamics[inspect]'",
                       "meshcat")
    return FileResponse(path, media_type="text/javascript", headers={"Cache-Control": "max-age=86400"})


@router.get(TRAJECTORY)
async def trajectory(request: Request) -> Response:
    data = getattr(request.app.state, "inspect_trajectory", None)
    if data is None:
        raise NotFound("trajectory: this server was given none (dynamics view ROBOT --trajectory FILE)",
                       "trajectory")
    return Response(data, media_type=JSON)


@router.get(PREFIX + "/{robot}")
async def robot_page(robot: str) -> Response:
    return _page()  # (the page reads the robot from its address)
