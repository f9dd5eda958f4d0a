"""Constrained dynamics benchmarks (issue 10, section 4): `python -m benchmarks.constraints`.

Constrained forward dynamics per state, ours (``constrained_forward_dynamics``: KKT through M^-1 with
minimum-norm multipliers) against Pinocchio's ``constraintDynamics`` (RigidConstraintModel, proximal
Cholesky), on the lectures' four-bar (robots/four_bar.urdf: a 3-D point closure of a planar loop, one row
redundant, so Pinocchio needs its proximal damping mu > 0 and iterations), the Cassie-like leg
(robots/cassie_like_leg.urdf, fixed and floating base, a full-rank point closure) and the 6-6 Stewart platform
(robots/stewart_platform.urdf: six point closures, 18 independent rows on 24 coordinates).  Batched: B states,
ours on all threads, Pinocchio in a Python loop over one Data (it has no batched form); single calls from Python.
Both sides of a ratio are timed alternately, best of --repeat (the machine is shared).  Before timing, the
accelerations are compared (the "check" column: largest relative difference).  A last table times the two
ways to get M for the KKT in a compiled loop (the O(n^2) articulated-body M^-1, against the CRBA and the
sparse L^T L factor, which the kernel uses).
Tables are printed and written to benchmarks/out/constraints.md.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

import numpy as np

from .core import PinMap, best_pair, machine_header, rel_diff

ROOT = Path(__file__).resolve().parent.parent
OUT = Path(__file__).resolve().parent / "out" / "constraints.md"


def cases(dyn):
    """(name, model with its closures, URDF path or text, floating, redundant rows, closed_states)."""
    fb_text = re.sub(r"<loop .*?</loop>", "", (ROOT / "robots/four_bar.urdf").read_text(), flags=re.S)
    fb = dyn.with_constraints(dyn.load_urdf(fb_text), [dyn.PointConstraint("link2", "link3", (0.35, 0, 0),
                                                                           (0.3, 0, 0))])
    leg = str(ROOT / "robots/cassie_like_leg.urdf")
    stewart = str(ROOT / "robots/stewart_platform.urdf")
    out = [("four-bar (point closure)", fb, fb_text, False, True, closed_states)]
    for floating in (False, True):
        out.append((f"Cassie-like leg{' (floating)' if floating else ''}", dyn.load_urdf(leg, floating_base=floating),
                    leg, floating, False, closed_states))
    out.append(("Stewart platform (6 point closures)", dyn.load_urdf(stewart), stewart, False, False,
                stewart_states))
    return out


def closed_states(dyn, model, B, rng):
    """B states on the constraint manifold (assembled from random guesses, velocities projected)."""
    free = [n for n in model.joint_names if n not in ("shin_joint", "tarsus_joint", "rod_pitch", "rod_roll",
                                                      "theta2", "phi1")]
    Q = np.empty((B, model.nq))
    base = None
    for b in range(min(B, 16)):  # assembly is not what we time: a few assembled states, repeated
        guess = model.neutral()
        if model.name == "four_bar":
            guess[:] = rng.uniform(-np.pi, np.pi), 0.5, 1.5
        else:
            guess[-9:] = rng.uniform(-0.3, 0.3, 9) * (np.arange(9) < 7)
        Q[b] = dyn.assemble(model, guess, fixed=free)
        base = b + 1
    Q[base:] = Q[np.arange(base, B) % base]
    V = dyn.project_velocity(model, Q, rng.normal(size=(B, model.nv)))
    T = rng.normal(size=(B, model.nv))
    return Q, V, T


def stewart_states(dyn, model, B, rng):
    """The Stewart platform: 16 platform poses within 5 cm and 0.1 rad of home, the legs assembled to each."""
    Q = np.empty((B, model.nq))
    for b in range(min(B, 16)):
        rotvec = rng.uniform(-0.1, 0.1, 3)
        angle = np.linalg.norm(rotvec)
        pose = np.r_[rng.uniform(-0.05, 0.05, 3), np.sin(angle / 2) * rotvec / angle, np.cos(angle / 2)]
        Q[b] = dyn.assemble(model, model.neutral(), fixed={"platform_joint": pose})
    base = min(B, 16)
    Q[base:] = Q[np.arange(base, B) % base]
    V = dyn.project_velocity(model, Q, rng.normal(size=(B, model.nv)))
    T = rng.normal(scale=20.0, size=(B, model.nv))
    return Q, V, T


def pinocchio_side(pin, model, source, floating):
    build = pin.buildModelFromXML if source.lstrip().startswith("<") else pin.buildModelFromUrdf
    pm = build(source, pin.JointModelFreeFlyer()) if floating else build(source)
    cm, cd = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for con in model.constraints:  # every closure is a point closure: CONTACT_3D
        A, B = pin.SE3(np.eye(3), np.array(con.point_a)), pin.SE3(np.eye(3), np.array(con.point_b))
        fa, fb = pm.frames[pm.getFrameId(con.frame_a)], pm.frames[pm.getFrameId(con.frame_b)]
        rcm = pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, pm, fa.parentJoint, fa.placement * A,
                                       fb.parentJoint, fb.placement * B, pin.LOCAL_WORLD_ALIGNED)
        cm.append(rcm)
        cd.append(rcm.createData())
    pd = pm.createData()
    pin.initConstraintDynamics(pm, pd, cm, cd)
    return pm, pd, cm, cd


def bench_case(dyn, pin, name, model, source, floating, redundant, states, B, repeat, rng):
    Q, V, T = states(dyn, model, B, rng)
    pm, pd, cm, cd = pinocchio_side(pin, model, source, floating)
    pmap = PinMap(model, pm)
    Qp, Vp, Tp = pmap.q(Q), pmap.v(V), pmap.v(T)
    # a redundant row needs Pinocchio's proximal damping; a full-rank closure takes one exact iteration
    prox = pin.ProximalSettings(1e-12, 1e-8, 50) if redundant else pin.ProximalSettings(1e-12, 0.0, 1)

    def pin_one(k):
        return pin.constraintDynamics(pm, pd, Qp[k], Vp[k], Tp[k], cm, cd, prox)

    A, _ = dyn.constrained_forward_dynamics(model, Q[:8], V[:8], T[:8])
    def back(ap):  # Pinocchio's v order -> ours
        a = np.empty(model.nv)
        a[pmap.v_perm] = ap
        return a

    check = max(rel_diff(A[k], back(pin_one(k))) for k in range(8))
    t_ours_b, t_pin_b = best_pair(lambda: dyn.constrained_forward_dynamics(model, Q, V, T),
                                  lambda: [pin_one(k) for k in range(B)], repeat)
    q, v, tau = Q[0].copy(), V[0].copy(), T[0].copy()
    t_ours_1, t_pin_1 = best_pair(lambda: dyn.constrained_forward_dynamics(model, q, v, tau), lambda: pin_one(0),
                                  repeat, number=200)
    return {"name": name, "nv": model.nv, "m": model.info["constraints"]["rows"], "check": check,
            "ours_b": t_ours_b / B, "pin_b": t_pin_b / B, "ours_1": t_ours_1, "pin_1": t_pin_1}


def us(t):
    return f"{t * 1e6:.2f}"


def table(header, rows) -> str:
    L = ["# Constrained dynamics benchmarks (`python -m benchmarks.constraints`)", ""] + header + [""]
    L += ["| mechanism | nv | rows | check | batched ours (us/state) | batched Pinocchio | ratio | single ours (us) "
          "| single Pinocchio | ratio |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        L.append(f"| {r['name']} | {r['nv']} | {r['m']} | {r['check']:.1e} | {us(r['ours_b'])} | {us(r['pin_b'])} | "
                 f"{r['ours_b'] / r['pin_b']:.2f} | {us(r['ours_1'])} | {us(r['pin_1'])} | "
                 f"{r['ours_1'] / r['pin_1']:.2f} |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=2000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    import pinocchio as pin

    import dynamics as dyn

    rng = np.random.default_rng(0)
    rows = []
    for name, model, source, floating, redundant, states in cases(dyn):
        rows.append(bench_case(dyn, pin, name, model, source, floating, redundant, states, args.batch, args.repeat,
                               rng))
    header = machine_header(args.batch, args.repeat)
    header[1] = re.sub(r"Pinocchio \d+ \(ModelPool\)", "Pinocchio in a Python loop over one Data", header[1])
    text = table(header, rows)
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
