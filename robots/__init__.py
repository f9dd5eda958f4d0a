"""The robots we wrote ourselves (textbook arms with their sources in each file's header).

    >>> import dynamics
    >>> model = dynamics.load_urdf(dynamics.robots.path("puma560"))

Bundled: cassie_like_leg, four_bar, pendulum, planar_2r, planar_3r, puma560, rp_arm, stewart_platform
(:func:`names`); ``dynamics.load_urdf``, the CLI and the service take these names as they are.
Installed as ``dynamics.robots``, so the files exist outside a checkout too.  Real robots for tests and
examples come from the ``example-robot-data`` package (see :func:`example_robot_data`).
"""

import importlib.metadata
import os
from pathlib import Path

HERE = Path(__file__).resolve().parent


def names() -> list[str]:
    """The bundled robots, by file name without .urdf."""
    return sorted(p.stem for p in HERE.glob("*.urdf"))


def path(name: str) -> str:
    """The path of bundled robot ``name`` ("puma560", "planar_2r", ... or the same with dashes)."""
    stem = str(name).removesuffix(".urdf").replace("-", "_")
    candidate = HERE / f"{stem}.urdf"
    if not candidate.is_file():
        raise FileNotFoundError(f"no bundled robot named {name!r}; bundled robots are {names()}")
    return str(candidate)


def example_robot_data(relative: str) -> str:
    """The path of a URDF shipped by the ``example-robot-data`` package (``pip install example-robot-data``),
    e.g. ``example_robot_data("panda_description/urdf/panda.urdf")``; the package has no Python module of its
    own any more, so its files are found through its installed metadata."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise FileNotFoundError("example-robot-data is not installed: pip install example-robot-data") from None
    for rel in ("cmeel.prefix/share/example-robot-data/robots", "share/example-robot-data/robots"):
        root = Path(str(dist.locate_file(rel)))
        if root.is_dir():
            target = root / relative
            if not target.is_file():
                raise FileNotFoundError(f"example-robot-data has no {relative!r} under {root}")
            return os.fspath(target)
    raise FileNotFoundError("example-robot-data is installed but its robots/ folder was not found")
