"""Derivatives benchmarks (issue 20, section 6): `python -m benchmarks.derivatives`.

Per robot (Panda, UR5, Talos floating; example-robot-data, found through the installed package), in one run:

* batched: per-state time of ``inverse_dynamics_derivatives`` and ``forward_dynamics_derivatives`` on B states
  (default 10,000; capped so that the (B, 3, nv, nv) answer stays under ~400 MB) on 2 threads, as ratios to a
  Python loop over Pinocchio's ``computeRNEADerivatives`` / ``computeABADerivatives`` (Pinocchio has no
  parallel version of them);
* single call from Python: one call of each against one call of Pinocchio's, on one state;
* constrained: ``constrained_forward_dynamics_derivatives`` against Pinocchio's ``constraintDynamics`` followed
  by ``computeConstraintDynamicsDerivatives`` (both give a, lambda and the six blocks), batched (B capped at
  2,000) and single, on the closed loops of benchmarks/constraints.py without redundant rows (the Cassie-like
  leg, fixed and floating, and the Stewart platform).  Its "check" compares the v and tau blocks only:
  Pinocchio's q blocks are wrong for loops between two moving bodies (tests/test_constrained_derivatives.py).

Ratios are ours / Pinocchio's (below 1.0 we are faster); the two sides of each ratio are measured alternately
(best of --repeat runs, benchmarks.core's conventions).  Before timing, our results are compared with
Pinocchio's on a few states (the "check" column: max relative difference).  The table is printed and written
to benchmarks/out/derivatives.md (git-ignored).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("DYNAMICS_NUM_THREADS", "2")

import numpy as np  # noqa: E402

from benchmarks.core import (PinMap, best_pair, benchmark_robots, load_as_pinocchio, load_pinocchio,  # noqa: E402
                             random_states, rel_diff)

OUT = Path(__file__).resolve().parent / "out" / "derivatives.md"
MAX_BYTES = 400 * 2**20


def check(dyn, pin, model, pm, pmap, Q, V, A, TAU):
    """Max relative difference of our derivatives and Pinocchio's on the given states."""
    pd, P = pm.createData(), np.ix_(pmap.v_perm, pmap.v_perm)  # our matrix in Pinocchio's order: X[P]
    err = 0.0
    for i in range(Q.shape[0]):
        q, v, a, t = pmap.q(Q[i:i + 1])[0], pmap.v(V[i:i + 1])[0], pmap.v(A[i:i + 1])[0], pmap.v(TAU[i:i + 1])[0]
        dq, dv, _ = dyn.inverse_dynamics_derivatives(model, Q[i], V[i], A[i])
        pin.computeRNEADerivatives(pm, pd, q, v, a)
        err = max(err, rel_diff(dq[P], pd.dtau_dq), rel_diff(dv[P], pd.dtau_dv))
        fq, fv, _ = dyn.forward_dynamics_derivatives(model, Q[i], V[i], TAU[i])
        pin.computeABADerivatives(pm, pd, q, v, t)
        err = max(err, rel_diff(fq[P], pd.ddq_dq), rel_diff(fv[P], pd.ddq_dv))
    return err


def bench_robot(dyn, pin, robot, B, repeat, rng):
    model = load_as_pinocchio(dyn, robot)
    pm = load_pinocchio(pin, robot)
    pmap = PinMap(model, pm)
    B = int(min(B, MAX_BYTES // (3 * 8 * model.nv ** 2)))
    Q, V, A, TAU = random_states(model, B, rng)
    Qp, Vp, Ap, TAUp = pmap.q(Q), pmap.v(V), pmap.v(A), pmap.v(TAU)
    pd = pm.createData()
    r = {"robot": robot.label, "nv": model.nv, "B": B, "check": check(dyn, pin, model, pm, pmap, Q[:3], V[:3],
                                                                        A[:3], TAU[:3])}

    def rnea_loop():
        for i in range(B):
            pin.computeRNEADerivatives(pm, pd, Qp[i], Vp[i], Ap[i])

    def aba_loop():
        for i in range(B):
            pin.computeABADerivatives(pm, pd, Qp[i], Vp[i], TAUp[i])

    r["id"], r["id_pin"] = (t / B for t in best_pair(lambda: dyn.inverse_dynamics_derivatives(model, Q, V, A),
                                                     rnea_loop, repeat))
    r["fd"], r["fd_pin"] = (t / B for t in best_pair(lambda: dyn.forward_dynamics_derivatives(model, Q, V, TAU),
                                                     aba_loop, repeat))
    q, v, a, t = (np.array(x[0]) for x in (Q, V, A, TAU))
    qp, vp, ap, tp = (np.array(x[0]) for x in (Qp, Vp, Ap, TAUp))
    n = 300 if model.nv > 30 else 2000
    r["sid"], r["sid_pin"] = best_pair(lambda: dyn.inverse_dynamics_derivatives(model, q, v, a),
                                       lambda: pin.computeRNEADerivatives(pm, pd, qp, vp, ap), 3 * repeat, n)
    r["sfd"], r["sfd_pin"] = best_pair(lambda: dyn.forward_dynamics_derivatives(model, q, v, t),
                                       lambda: pin.computeABADerivatives(pm, pd, qp, vp, tp), 3 * repeat, n)
    return r


def bench_constrained(dyn, pin, B, repeat, rng):
    """One row per closed-loop case of benchmarks/constraints.py without redundant rows (module docstring)."""
    from benchmarks.constraints import cases, pinocchio_side

    rows = []
    for name, model, source, floating, redundant, states in cases(dyn):
        if redundant:  # Pinocchio's derivatives need its exact (undamped) solve
            continue
        Q, V, T = states(dyn, model, B, rng)
        pm, pd, cm, cd = pinocchio_side(pin, model, source, floating)
        pmap = PinMap(model, pm)
        P = pmap.v_perm
        Qp, Vp, Tp = pmap.q(Q), pmap.v(V), pmap.v(T)
        prox = pin.ProximalSettings(1e-12, 0.0, 1)

        def pin_one(k):
            pin.constraintDynamics(pm, pd, Qp[k], Vp[k], Tp[k], cm, cd, prox)
            pin.computeConstraintDynamicsDerivatives(pm, pd, cm, cd, prox)

        check = 0.0
        for k in range(3):
            ours = dyn.constrained_forward_dynamics_derivatives(model, Q[k], V[k], T[k])
            pin_one(k)
            for x, y in ((ours[1], pd.ddq_dv), (ours[2], pd.ddq_dtau)):  # ours in Pinocchio's order: X[P]
                check = max(check, rel_diff(x[np.ix_(P, P)], np.array(y)))
            for x, y in ((ours[4], pd.dlambda_dv), (ours[5], pd.dlambda_dtau)):
                check = max(check, rel_diff(x[:, P], np.array(y)))
        r = {"robot": name, "nv": model.nv, "m": model.info["constraints"]["rows"], "B": B, "check": check}
        r["b"], r["b_pin"] = (t / B for t in best_pair(
            lambda: dyn.constrained_forward_dynamics_derivatives(model, Q, V, T),
            lambda: [pin_one(k) for k in range(B)], repeat))
        q, v, tau = Q[0].copy(), V[0].copy(), T[0].copy()
        r["s"], r["s_pin"] = best_pair(lambda: dyn.constrained_forward_dynamics_derivatives(model, q, v, tau),
                                       lambda: pin_one(0), 3 * repeat, 300)
        rows.append(r)
        print(name, "done", flush=True)
    return rows


def constrained_table(rows, threads):
    us = 1e6
    out = [f"Constrained forward dynamics derivatives (a, lambda and the six blocks; {threads} threads batched) "
           "against Pinocchio's constraintDynamics + computeConstraintDynamicsDerivatives; check: the v and tau "
           "blocks.", "",
           "| case | nv | m | B | check | batched (us) | Pinocchio loop (us) | ratio | single (us) | Pinocchio (us) "
           "| ratio |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        cells = [r["robot"], r["nv"], r["m"], r["B"], f"{r['check']:.1e}"]
        for k in ("b", "s"):
            cells += [f"{r[k] * us:.2f}", f"{r[k + '_pin'] * us:.2f}", f"{r[k] / r[k + '_pin']:.2f}"]
        out.append("| " + " | ".join(str(c) for c in cells) + " |")
    return "\n".join(out)


def table(rows, threads):
    us = 1e6
    out = [f"Batched: per-state time on B states ({threads} threads) against a Python loop over Pinocchio's "
           "function; single: one call from Python each.  Ratio = ours / Pinocchio's (below 1: faster).", "",
           "| robot | nv | B | check | batched ID derivs (us) | Pinocchio loop (us) | ratio "
           "| batched FD derivs (us) | Pinocchio loop (us) | ratio | single ID derivs (us) | Pinocchio (us) "
           "| ratio | single FD derivs (us) | Pinocchio (us) | ratio |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        cells = [r["robot"], r["nv"], r["B"], f"{r['check']:.1e}"]
        for k in ("id", "fd", "sid", "sfd"):
            cells += [f"{r[k] * us:.2f}", f"{r[k + '_pin'] * us:.2f}", f"{r[k] / r[k + '_pin']:.2f}"]
        out.append("| " + " | ".join(str(c) for c in cells) + " |")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--batch", type=int, default=10_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--constrained-only", action="store_true", help="only the constrained dynamics table")
    ap.add_argument("--no-constrained", action="store_true", help="only the robots' table (ID and FD derivatives)")
    args = ap.parse_args(argv)
    import pinocchio as pin

    import dynamics as dyn
    from dynamics.parallel import num_threads

    rng = np.random.default_rng(0)
    rows = []
    for robot in [] if args.constrained_only else benchmark_robots():
        if robot.label.startswith("chain"):
            continue
        rows.append(bench_robot(dyn, pin, robot, args.batch, args.repeat, rng))
        print(rows[-1]["robot"], "done", flush=True)
    text = table(rows, num_threads()) if rows else ""
    if not args.no_constrained:
        text += "\n\n" if text else ""
        text += constrained_table(bench_constrained(dyn, pin, min(args.batch, 2000), args.repeat, rng),
                                  num_threads())
    print(text)
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(f"# Derivatives benchmark (`python -m benchmarks.derivatives`)\n\n{text}\n")


if __name__ == "__main__":
    main()
