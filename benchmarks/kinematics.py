"""Kinematics benchmarks (issue 9, section 5): `python -m benchmarks.kinematics`.

Per robot (Panda, UR5, Talos with a free-flyer, from example-robot-data), in one run, ours against Pinocchio:

* forward kinematics of every frame (Pinocchio: `forwardKinematics` + `updateFramePlacements`),
* one frame's Jacobian, local_world_aligned (`computeFrameJacobian`),
* the centre of mass (`centerOfMass`) and its Jacobian (`jacobianCenterOfMass`),
* M^-1 (`computeMinverse`),

batched (B states, default 10,000; ours on 2 threads, Pinocchio, which has no batched form of these, in a
Python loop over one Data) and single calls from Python.  Ratios are ours / Pinocchio's (< 1: we are
faster); both sides of a ratio are timed alternately, best of --repeat runs (the machine is shared).  Before
timing, results are compared with Pinocchio's on a few states (the "check" column: largest relative
difference).  Tables are printed and written to benchmarks/out/kinematics.md.

Single calls are timed as many short samples (200 calls each), so that the best of them misses the other
processes of a shared machine.  A last column gives the batched work on one thread as CPU time
(``time.thread_time``, ours in slices below the parallel threshold, Pinocchio's loop): on a loaded machine the
2-thread wall-clock ratio mostly measures how much of the second core we got; this one does not.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path

import numpy as np

from dynamics import parallel

from .core import PinMap, Robot, best_pair, erd_robots_dir, load_pinocchio, machine_header, random_states, rel_diff

OUT = Path(__file__).resolve().parent / "out" / "kinematics.md"
#: output memory cap of one batched call (M^-1 and all frames' placements are large on Talos)
BATCH_BYTES = 400 * 2**20


def robots():
    d = erd_robots_dir()
    return [
        (Robot("Panda", str(d / "panda_description/urdf/panda.urdf")), "panda_hand"),
        (Robot("UR5", str(d / "ur_description/urdf/ur5_robot.urdf")), "tool0"),
        (Robot("Talos (floating)", str(d / "talos_data/robots/talos_full_v2.urdf"), True), "gripper_left_base_link"),
    ]


def bench_robot(dyn, pin, robot, frame, B, repeat, rng):
    model = dyn.load_urdf(robot.source, floating_base=robot.floating_base)
    pm = load_pinocchio(pin, robot)
    pd = pm.createData()
    pmap = PinMap(model, pm)
    Q = random_states(model, B, rng)[0]
    Qp = pmap.q(Q)
    fid = pm.getFrameId(frame)
    perm = pmap.v_perm  # pin v index -> our v index
    LWA = pin.LOCAL_WORLD_ALIGNED

    def fk_pin(q):
        pin.forwardKinematics(pm, pd, q)
        pin.updateFramePlacements(pm, pd)

    # (name, ours batched on Q[:n], pin on one state, ours single, bytes of output per state)
    cases = [
        ("FK (all frames)", lambda X: dyn.forward_kinematics(model, X), fk_pin,
         lambda q: dyn.forward_kinematics(model, q), 128 * len(model.frames)),
        ("frame Jacobian", lambda X: dyn.frame_jacobian(model, X, frame),
         lambda q: pin.computeFrameJacobian(pm, pd, q, fid, LWA), lambda q: dyn.frame_jacobian(model, q, frame),
         48 * model.nv),
        ("centre of mass", lambda X: dyn.center_of_mass(model, X), lambda q: pin.centerOfMass(pm, pd, q),
         lambda q: dyn.center_of_mass(model, q), 24),
        ("com Jacobian", lambda X: dyn.com_jacobian(model, X), lambda q: pin.jacobianCenterOfMass(pm, pd, q),
         lambda q: dyn.com_jacobian(model, q), 24 * model.nv),
        ("M^-1", lambda X: dyn.inverse_mass_matrix(model, X), lambda q: pin.computeMinverse(pm, pd, q),
         lambda q: dyn.inverse_mass_matrix(model, q), 8 * model.nv**2),
    ]

    # same results on both sides (and everything compiled before timing)
    check = 0.0
    for k in range(3):
        q, qp = Q[k].copy(), Qp[k].copy()
        fk_pin(qp)
        T = dyn.forward_kinematics(model, q)
        check = max(check, rel_diff(T[model.frame_index(frame)], pd.oMf[fid].homogeneous))
        check = max(check, rel_diff(dyn.frame_jacobian(model, q, frame)[:, perm],
                                    pin.computeFrameJacobian(pm, pd, qp, fid, LWA)))
        check = max(check, rel_diff(dyn.center_of_mass(model, q), pin.centerOfMass(pm, pd, qp)))
        check = max(check, rel_diff(dyn.com_jacobian(model, q)[:, perm], pin.jacobianCenterOfMass(pm, pd, qp)))
        Mp = pin.computeMinverse(pm, pd, qp)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        check = max(check, rel_diff(dyn.inverse_mass_matrix(model, q)[np.ix_(perm, perm)], Mp))

    rows = []
    for name, ours_b, pin_1, ours_1, nbytes in cases:
        n = int(min(B, max(100, BATCH_BYTES // nbytes)))
        X, Xp = Q[:n], Qp[:n]
        ours_b(X[:2])

        def pin_loop():
            for i in range(n):
                pin_1(Xp[i])

        m = min(n, 2000)

        def ours_1thread():
            with one_thread():
                ours_b(X[:m])

        def pin_part():
            for i in range(m):
                pin_1(Xp[i])

        tb, tb_pin = best_pair(lambda: ours_b(X), pin_loop, repeat)
        tc, tc_pin = best_cpu_pair(ours_1thread, pin_part, repeat)
        q, qp = Q[0].copy(), Qp[0].copy()
        ts, ts_pin = best_pair(lambda: ours_1(q), lambda: pin_1(qp), 20 * repeat, 200)
        rows.append({"robot": robot.label, "nv": model.nv, "what": name, "B": n, "batch": tb / n,
                     "batch_pin": tb_pin / n, "single": ts, "single_pin": ts_pin, "cpu_ratio": tc / tc_pin,
                     "check": check})
    return rows


def best_cpu_pair(fa, fb, repeat):
    """The best CPU time of the calling thread for two functions, measured alternately."""
    best = [float("inf"), float("inf")]
    for _ in range(repeat):
        for k, f in enumerate((fa, fb)):
            t0 = time.thread_time()
            f()
            best[k] = min(best[k], time.thread_time() - t0)
    return best


@contextlib.contextmanager
def one_thread():
    """Our batches on the calling thread only (as DYNAMICS_NUM_THREADS=1, which is read once per process)."""
    saved, parallel._threads = parallel._threads, 1
    try:
        yield
    finally:
        parallel._threads = saved


def table(header, rows):
    us = lambda t: f"{t * 1e6:.2f}"  # noqa: E731
    L = ["# Kinematics benchmarks (`python -m benchmarks.kinematics`)", ""] + header + [""]
    L += [
        "| robot | nv | quantity | ours batched (us/state) | pin loop (us/state) | ratio | one call (us) "
        "| one pin call (us) | ratio | 1-thread CPU ratio | check |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        L.append(f"| {r['robot']} | {r['nv']} | {r['what']} | {us(r['batch'])} | {us(r['batch_pin'])} "
                 f"| {r['batch'] / r['batch_pin']:.2f} | {us(r['single'])} | {us(r['single_pin'])} "
                 f"| {r['single'] / r['single_pin']:.2f} | {r['cpu_ratio']:.2f} | {r['check']:.0e} |")
    capped = sorted({f"{r['robot']} {r['what']}: {r['B']}" for r in rows if r["B"] < max(x["B"] for x in rows)})
    L += ["", "Targets: batched ratio <= 1.0, single-call ratio <= 1.5.  check = largest relative difference from "
          "Pinocchio over the placement, Jacobian, centre of mass, its Jacobian and M^-1 on 3 states.  1-thread CPU "
          "ratio = the batched work (2,000 states at most) on one thread, thread CPU time, ours / Pinocchio's loop."]
    if capped:
        L.append(f"Batches capped at {BATCH_BYTES >> 20} MiB of output: " + ", ".join(capped) + " states.")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--states", type=int, default=10_000, help="batch size (default 10000)")
    p.add_argument("--repeat", type=int, default=5, help="best of N runs (default 5)")
    p.add_argument("--quick", action="store_true", help="1000 states, best of 2")
    args = p.parse_args(argv)
    B, repeat = (1000, 2) if args.quick else (args.states, args.repeat)

    import pinocchio as pin

    import dynamics as dyn

    rng = np.random.default_rng(0)
    rows = []
    for robot, frame in robots():
        print(f"... {robot.label}", file=sys.stderr, flush=True)
        rows += bench_robot(dyn, pin, robot, frame, B, repeat, rng)
    from dynamics.parallel import num_threads

    header = machine_header(B, repeat)[:1] + [
        f"Batched runs: {B} states; our batch on {num_threads()} threads, Pinocchio in a Python loop over one Data "
        f"(it has no batched form of these).  Every time is the best of {repeat} runs.  Ratio = ours / Pinocchio "
        f"(< 1: we are faster)."]
    report = table(header, rows)
    print(report)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(report)
    print(f"(written to {OUT})", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
