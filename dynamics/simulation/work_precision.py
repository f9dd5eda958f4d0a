"""Error against run time for the user's own problem: which integrator and tolerance to pick.

``work_precision(model, q0, v0, duration)`` runs each integrator at each tolerance (adaptive methods) or step
(fixed-step methods), measures the error of the final state against a tight reference run (DOP853 at
``reference_tol``, the max-norm over the manifold difference of q and the difference of v, as
``report["error_estimate"]``) and the wall time of the integration alone (the best of ``repeat`` runs,
``report["wall_time_s"]``), and returns the table, with the matplotlib figure when ``plot`` is set.
"""

from typing import NamedTuple

import numpy as np

from .. import plot as plotting
from ..errors import InputError
from .report import state_error
from .simulate import INTEGRATORS, simulate
from .solvers import FIXED


class WorkPrecision(NamedTuple):
    """rows: one dict per run (integrator, tolerance, dt, error, wall_time_s, rhs_evals, steps, status);
    reference: the reference run's settings and cost; figure: the matplotlib Figure or None."""

    rows: list
    reference: dict
    figure: object


def work_precision(model, q0, v0, duration, *, integrators=("rk45", "dop853", "radau", "auto"),
                   tolerances=(1e-4, 1e-6, 1e-8, 1e-10), dts=(1e-2, 3e-3, 1e-3), torque=None,
                   reference_tol=1e-13, repeat=3, plot=False, **simulate_options):
    """The work-precision table of ``simulate(model, q0, v0, duration, torque=torque, **simulate_options)``.

    Adaptive integrators run at rtol = atol = each of ``tolerances``, fixed-step ones at each of ``dts``.
    plot: False, True (return the figure) or a path to save it to.  Returns :class:`WorkPrecision`.
    """
    for name in integrators:
        if name not in INTEGRATORS:
            raise InputError(f"integrators: expected names from {INTEGRATORS}, got {name!r}")
    opts = dict(simulate_options, torque=torque, error_estimate="none", outputs=("q", "v"), progress=False)
    opts["sample_dt"] = max(float(duration), 1e-300)  # only the first and last samples
    ref = simulate(model, q0, v0, duration, integrator="dop853", rtol=reference_tol, atol=reference_tol, **opts)
    if ref.report["status"] != "ok":
        raise InputError(f"work_precision: the reference run failed ({ref.report['status']})")
    rows = []
    for name in integrators:
        settings = [dict(dt=dt) for dt in dts] if name in FIXED else [dict(rtol=tol, atol=tol) for tol in tolerances]
        for kw in settings:
            runs = [simulate(model, q0, v0, duration, integrator=name, **kw, **opts) for _ in range(max(1, repeat))]
            tr = min(runs, key=lambda r: r.report["wall_time_s"])
            r = tr.report
            ok = r["status"] == "ok"
            err = max(state_error(model, tr.q[-1], tr.v[-1], ref.q[-1], ref.v[-1])) if ok else float("inf")
            rows.append({"integrator": name, "tolerance": kw.get("rtol"), "dt": kw.get("dt"), "error": err,
                         "wall_time_s": r["wall_time_s"], "rhs_evals": r["rhs_evals"], "steps": r["steps"],
                         "status": r["status"]})
    reference = {"integrator": "dop853", "tolerance": reference_tol, "wall_time_s": ref.report["wall_time_s"],
                 "rhs_evals": ref.report["rhs_evals"]}
    figure = _figure(rows, plot) if plot else None
    return WorkPrecision(rows, reference, figure)


def _figure(rows, plot):
    plt = plotting.pyplot()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    for name in dict.fromkeys(r["integrator"] for r in rows):
        pts = [(r["wall_time_s"], r["error"]) for r in rows if r["integrator"] == name and np.isfinite(r["error"]) and r["error"] > 0]
        if pts:
            ax.loglog(*zip(*sorted(pts)), "o-", label=name)
    ax.set_xlabel("wall time of the run (s)")
    ax.set_ylabel("error of the final state (vs tight reference)")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.tight_layout()
    if isinstance(plot, (str, bytes)) or hasattr(plot, "__fspath__"):
        fig.savefig(plot, dpi=120)
    return fig
