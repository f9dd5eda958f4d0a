"""Figures with matplotlib (an optional extra: ``pip install 'dynamics[plot]'``).

:func:`trajectory` draws a simulated trajectory: joint positions, velocities and the applied torques against
time, one line per coordinate, and the report's verdict (integrator, status, error estimate, energy drift,
cost) in the title, so a figure saved from a run says how far it can be trusted.
"""

import importlib
import os

import numpy as np

from .errors import InputError

MAX_LEGEND = 10  # more coordinates than this get no legend (it would cover the lines)


def pyplot():
    """matplotlib.pyplot with a non-interactive backend when no display is attached, or a clear error."""
    try:
        matplotlib = importlib.import_module("matplotlib")
    except ImportError:
        raise ImportError("plotting needs matplotlib: pip install 'dynamics[plot]' (or pip install matplotlib)") \
            from None
    if not os.environ.get("DISPLAY") and not os.environ.get("MPLBACKEND"):
        matplotlib.use("Agg")  # no screen: draw to files only
    return importlib.import_module("matplotlib.pyplot")


def report_title(report):
    """One line summarising a simulation report."""
    parts = [str(report.get("integrator", "")), f"status {report.get('status', '?')}"]
    for key, label in (("error_estimate", "error"), ("energy_drift", "energy drift")):
        value = report.get(key)
        if isinstance(value, (int, float)) and np.isfinite(value):
            parts.append(f"{label} {value:.1e}")
    if "steps" in report:
        parts.append(f"{report['steps']} steps")
    if "wall_time_s" in report:
        parts.append(f"{report['wall_time_s'] * 1e3:.0f} ms")
    return ", ".join(p for p in parts if p)


def trajectory(traj, path=None, *, joint_names=None, show=False):
    """Plot q, v and tau of a :class:`~dynamics.Trajectory` against t; save to ``path`` (png, pdf, svg) if given.
    Returns the matplotlib Figure."""
    plt = pyplot()
    panels = [(name, np.asarray(getattr(traj, name))) for name in ("q", "v", "tau")]
    panels = [(n, x) for n, x in panels if x.ndim == 2 and x.shape[0] == len(traj.t) and x.size]
    if not panels:
        raise InputError("trajectory: nothing to plot (no q, v or tau samples)")
    fig, axes = plt.subplots(len(panels), 1, sharex=True, figsize=(8, 2.4 * len(panels) + 0.6), squeeze=False)
    units = {"q": "position (rad, m)", "v": "velocity (rad/s, m/s)", "tau": "torque (N m, N)"}
    for ax, (name, x) in zip(axes[:, 0], panels):
        labels = list(joint_names or []) if name != "q" or x.shape[1] == len(joint_names or []) else []
        for k in range(x.shape[1]):
            ax.plot(traj.t, x[:, k], lw=1, label=labels[k] if k < len(labels) else f"{name}[{k}]")
        ax.set_ylabel(units[name])
        ax.grid(alpha=0.3)
        if x.shape[1] <= MAX_LEGEND:
            ax.legend(fontsize=7, loc="upper right", ncol=min(5, x.shape[1]))
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(report_title(traj.report), fontsize=9)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    if show:
        plt.show()
    return fig
