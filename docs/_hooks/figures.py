"""MkDocs hook: the simulation page's figure, made when the site is built by the call the page shows.

The PD run of the 2R arm in ``guide/simulation.md`` is simulated and plotted with ``dynamics.plot.trajectory``
(matplotlib's Agg backend, no display), and the PNG is added to the site as ``guide/pd_run.png``: the figure
is always the current code's, and no image of it is kept in git.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[2]
FIGURE = "guide/pd_run.png"


def pd_run_png() -> bytes:
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    import matplotlib

    matplotlib.use("Agg")
    import numpy as np

    import dynamics
    from dynamics.torques import PD

    arm = dynamics.load_urdf(dynamics.robots.path("planar_2r"))
    target = np.array([0.8, -0.4])
    pd = dynamics.simulate(arm, [0.5, 0.2], [0, 0], 2.0, torque=PD(target, 2000.0, 200.0), sample_dt=0.01,
                           progress=False)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "pd_run.png"
        fig = dynamics.plot.trajectory(pd, path, joint_names=arm.joint_names)
        matplotlib.pyplot.close(fig)
        return path.read_bytes()


def on_files(files, config):
    files.append(File.generated(config, FIGURE, content=pd_run_png()))
    return files
