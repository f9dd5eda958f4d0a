"""One-off: the core's constrained inverse dynamics and constrained FD derivatives against the numba kernels they
replace (commit 7b96f40), on the four-bar, the Stewart platform and the Cassie-like leg (fixed and floating base)
at random states.  `python -m benchmarks.numba_agreement_constrained` from a checkout with git; the old modules
are read from git and loaded beside the package for the run (numba goes away soon; then this script goes too).

Prints, per case, the number of states whose results are the same bits and the largest relative difference
(max |core - numba| / max(1, max |numba|), per state and block).
"""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import numpy as np

import dynamics as dyn
from dynamics.constraints import arrays

ROOT = Path(__file__).resolve().parent.parent
OLD = "7b96f40"
PASSIVE = ("shin_joint", "tarsus_joint", "rod_pitch", "rod_roll", "theta2", "phi1")


def load_old():
    """The old numba modules, written beside the package as dynamics/_old_*.py (removed by the caller)."""
    files = {"_old_constrained_dynamics": "dynamics/constrained_dynamics.py",
             "_old_constrained_derivatives": "dynamics/constrained_derivatives.py"}
    paths = []
    for name, path in files.items():
        text = subprocess.run(["git", "show", f"{OLD}:{path}"], cwd=ROOT, check=True, capture_output=True,
                              text=True).stdout
        text = text.replace("from .constrained_dynamics import", "from ._old_constrained_dynamics import")
        p = ROOT / "dynamics" / f"{name}.py"
        p.write_text(text)
        paths.append(p)
    try:
        return paths, [importlib.import_module(f"dynamics.{n}") for n in files]
    except BaseException:
        for p in paths:
            p.unlink()
        raise


def cases():
    out = [("four-bar", dyn.load_urdf(str(ROOT / "robots/four_bar.urdf")))]
    for floating in (False, True):
        out.append((f"Cassie-like leg{' (floating)' if floating else ''}",
                    dyn.load_urdf(str(ROOT / "robots/cassie_like_leg.urdf"), floating_base=floating)))
    out.append(("Stewart platform", dyn.load_urdf(str(ROOT / "robots/stewart_platform.urdf"))))
    return out


def random_states(model, B, rng):
    Q = np.empty((B, model.nq))
    for b in range(B):
        Q[b] = dyn.integrate(model, model.neutral(), rng.uniform(-0.4, 0.4, model.nv))
    return Q, rng.normal(size=(B, model.nv)), rng.normal(size=(B, model.nv)) * 5.0


def compare(new, old):
    """(same bits, largest relative difference) over the states (first axis)."""
    same, worst = 0, 0.0
    for n, o in zip(new, old):
        same += int(np.array_equal(n, o))
        worst = max(worst, float(np.max(np.abs(n - o)) / max(1.0, np.max(np.abs(o)))))
    return same, worst


def residual(model, q, v, a, tau):
    """|P (f - tau)| / |f|: what of M a + C v + g - tau the loops' forces J^T lambda cannot take."""
    f = dyn.inverse_dynamics(model, q, v, a)
    J = dyn.constraint_jacobian(model, q)
    r = f - tau
    lam = np.linalg.lstsq(J.T, r, rcond=None)[0]
    return np.max(np.abs(r - J.T @ lam)) / max(1.0, np.max(np.abs(f)))


def id_row(old_cd, name, label, model, C, g, Q, V, A, actuated):
    """Constrained ID, state by state: statuses, bits, largest relative difference and both residuals."""
    mask = np.zeros(model.nv)
    for j in actuated:
        mask[model.v_slice(j)] = 1.0
    B = Q.shape[0]
    old = np.empty((B, model.nv))
    status = np.empty(B, np.int64)
    old_cd._constrained_id_batch(model.tree, Q, V, A, C, g, mask, old, status)
    agree, same, worst, res_new, res_old = 0, 0, 0.0, 0.0, 0.0
    for b in range(B):
        try:
            new = dyn.constrained_inverse_dynamics(model, Q[b], V[b], A[b], actuated=actuated)
            code = 0
        except dyn.InputError as e:
            code = 2 if str(e).startswith("actuated") else 1
        agree += int(code == status[b])
        if code == 0 and status[b] == 0:
            s, w = compare(new[None], old[b][None])
            same, worst = same + s, max(worst, w)
            res_new = max(res_new, residual(model, Q[b], V[b], A[b], new))
            res_old = max(res_old, residual(model, Q[b], V[b], A[b], old[b]))
    print(f"{name:28s} {'constrained ID, ' + label:34s} {B:6d} {same:13d} {worst:12.1e}   statuses agree "
          f"{agree}/{B}; residual core {res_new:.1e}, numba {res_old:.1e}")


def main():
    paths, (old_cd, old_deriv) = load_old()
    try:
        rng = np.random.default_rng(7)
        B = 200
        print(f"{'case':28s} {'what':34s} {'states':>6s} {'bit-identical':>13s} {'max rel diff':>12s}")
        for name, model in cases():
            C, m = arrays(model)
            g = np.array(model.gravity, float)
            Q, V, T = random_states(model, B, rng)
            for gains in ((0.0, 0.0), (10.0, 10.0)):
                new = dyn.constrained_forward_dynamics_derivatives(model, Q, V, T, baumgarte=gains or None)
                new = np.stack([np.concatenate([new[i], new[3 + i]], axis=1) for i in range(3)], axis=1)
                old = np.empty((B, 3, model.nv + m, model.nv))
                status = np.empty(B, np.int64)
                old_deriv._derivatives_batch(model.tree, Q, V, T, C, g, gains[0], gains[1], old, status)
                assert np.all(status < 0)
                same, worst = compare(new, old)
                print(f"{name:28s} {'FD derivatives, Baumgarte ' + str(gains):34s} {B:6d} {same:13d} {worst:12.1e}")
                one = dyn.constrained_forward_dynamics_derivatives(model, Q[0], V[0], T[0], baumgarte=gains or None)
                assert all(np.array_equal(x, y) for x, y in zip(one, (new[0, i, :model.nv] for i in range(3)))), \
                    "single call and batch differ"
            A, _ = dyn.constrained_forward_dynamics(model, Q, V, T)
            sets = [("all joints", list(model.joint_names)),
                    ("the motors", [j for j in model.joint_names if j not in PASSIVE])]
            if "rod_pitch" in model.joint_names:  # the leg's mobility: the motors and one rod joint
                sets.append(("the motors and rod_pitch", sets[1][1] + ["rod_pitch"]))
            for label, actuated in sets:
                id_row(old_cd, name, label, model, C, g, Q, V, A, actuated)
    finally:
        for p in paths:
            p.unlink()


if __name__ == "__main__":
    sys.exit(main())
