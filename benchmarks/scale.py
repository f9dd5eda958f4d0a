"""Scaling out (issue: beyond one machine): `python -m benchmarks.scale [--quick] [--rounds R] [--simulations-only]`.

In one run, on this machine:

* simulations: N Panda runs (PD towards random targets from random states, 1 s, the default integrator)
  through ``dynamics.simulate_many`` with engine="threads", "processes" and "ray" (a local Ray with the
  machine's CPUs), against the ideal = single-core time per run x N / cores (measured on a sample of runs
  on one thread, scaled to the N runs by their right-hand-side evaluations);
* inverse dynamics: S Talos states (floating base, nv = 38) through ``dynamics.map_batches`` on threads and Ray
  (it runs "processes" on threads),
  in blocks of 1 M states (inputs are generated per block: 10 M states of q, v, a are ~9 GB);
* Ray's start-up time and its per-task overhead (empty tasks), and the cost of moving one chunk's result.

From the measured per-chunk costs it derives what N machines would give, and where the bottleneck moves
(printed under the tables).  Tables go to stdout and benchmarks/out/scale.md.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

import dynamics
from dynamics import engines, parallel
from dynamics.torques import PD

OUT = Path(__file__).resolve().parent / "out" / "scale.md"
BLOCK = 1_000_000


def panda():
    """The open tree (fingers independent, random q0 not coupled): the figures measure the engines' scaling of
    the README's table, which was taken on the tree."""
    return dynamics.load_urdf(dynamics.robots.example_robot_data("panda_description/urdf/panda.urdf"),
                              mimic="independent")


def talos():
    return dynamics.load_urdf(dynamics.robots.example_robot_data("talos_data/robots/talos_reduced.urdf"),
                              floating_base=True, strict_inertia=False)


def sim_inputs(model, n, rng):
    lo = np.nan_to_num(model.lower, neginf=-1.0)
    hi = np.nan_to_num(model.upper, posinf=1.0)
    q0 = rng.uniform(lo, hi, (n, model.nq))
    targets = rng.uniform(lo, hi, (n, model.nq))
    return q0, [PD(targets[k], 200.0, 20.0, tau_ff=dynamics.gravity_torques(model, targets[k])) for k in range(n)]


def bench_simulations(n, sample, cores, engines_=engines.ENGINES, rounds=1):
    """Per round, alternately: ``sample`` runs one after the other on this thread (the single-core time), then the
    N runs through simulate_many on each engine; efficiency per round against that round's single-core time (a
    shared machine's load moves both alike), the median over rounds reported.

    The runs differ in length (3-20 ms: the steps each needs), so the sample's time is scaled to the N runs by
    their right-hand-side evaluations (the same on every engine: the runs are bit-identical): ideal = sample time
    x (evaluations of the N runs / evaluations of the sample) / cores.  (The first 100 of benchmarks' 1,000 runs
    need 1.7 % fewer evaluations than the 1,000 on average; unscaled, that read as 1.7 % of lost efficiency.)"""
    model = panda()
    rng = np.random.default_rng(0)
    q0, pds = sim_inputs(model, n, rng)
    v0 = np.zeros(model.nv)
    opts = dict(error_estimate="none", sample_dt=0.01, progress=False)
    dynamics.simulate(model, q0[0], v0, 1.0, torque=pds[0], **opts)  # first call
    singles, per_engine = [], {engine: [] for engine in engines_}
    for _ in range(rounds):
        t0 = time.perf_counter()
        work = 0
        for k in range(sample):
            work += dynamics.simulate(model, q0[k], v0, 1.0, torque=pds[k], **opts).report["rhs_evals"]
        single = (time.perf_counter() - t0) / sample
        singles.append(single)
        for engine in engines_:
            t0 = time.perf_counter()
            out = dynamics.simulate_many(model, q0, v0, 1.0, torque=pds, engine=engine, **opts)
            wall = time.perf_counter() - t0
            assert out.ok.all(), [r["status"] for r in out.reports if r["status"] != "ok"][:3]
            scale = sum(r["rhs_evals"] for r in out.reports) / (work * n / sample)  # the N runs' work per run
            per_engine[engine].append((wall, single * scale * n / cores / wall, single * n / cores / wall))
    rows = []
    for engine, rs in per_engine.items():
        wall = float(np.median([r[0] for r in rs]))
        effs = [r[1] for r in rs]
        rows.append({"engine": engine, "wall": wall, "throughput": n / wall, "efficiency": float(np.median(effs)),
                     "efficiencies": effs, "unscaled": float(np.median([r[2] for r in rs]))})
    return {"n": n, "single": float(np.median(singles)), "rows": rows}


def bench_inverse_dynamics(total, cores):
    model = talos()
    rng = np.random.default_rng(1)
    small = rng.uniform(-1, 1, (20_000, model.nq))
    small[:, 3:7] /= np.linalg.norm(small[:, 3:7], axis=1)[:, None]
    vs = rng.uniform(-1, 1, (20_000, model.nv))
    os.environ.setdefault("DYNAMICS_NUM_THREADS", str(cores))
    dynamics.inverse_dynamics(model, small[:100], vs[:100], vs[:100])
    single = _single_thread_time(model, small, vs)
    rows = []
    for engine in (e for e in engines.ENGINES if e != "processes"):  # map_batches runs "processes" on threads
        wall = 0.0
        for start in range(0, total, BLOCK):
            b = min(BLOCK, total - start)
            Q = rng.uniform(-1, 1, (b, model.nq))
            Q[:, 3:7] /= np.linalg.norm(Q[:, 3:7], axis=1)[:, None]
            V, A = rng.uniform(-1, 1, (2, b, model.nv))
            t0 = time.perf_counter()
            dynamics.map_batches(dynamics.inverse_dynamics, model, Q, V, A, engine=engine, progress=False)
            wall += time.perf_counter() - t0
        rows.append({"engine": engine, "wall": wall, "throughput": total / wall,
                     "efficiency": single * total / cores / wall})
    return {"n": total, "single": single, "rows": rows, "nv": model.nv}


def _single_thread_time(model, Q, V):
    """Per-state time of one thread (the chunks of a batch on one core)."""
    saved = parallel._threads
    parallel._threads = 1
    try:
        best = np.inf
        for _ in range(3):
            t0 = time.perf_counter()
            dynamics.inverse_dynamics(model, Q, V, V)
            best = min(best, time.perf_counter() - t0)
    finally:
        parallel._threads = saved
    return best / Q.shape[0]


def bench_ray_overheads(cores):
    ray = engines.ray_module()
    t0 = time.perf_counter()
    engines.ray_init(num_cpus=cores)
    start = time.perf_counter() - t0
    noop = ray.remote(lambda x: x)
    ray.get([noop.remote(0) for _ in range(50)])  # workers up
    t0 = time.perf_counter()
    ray.get([noop.remote(0) for _ in range(2000)])
    per_task = (time.perf_counter() - t0) / 2000
    chunk = np.zeros((10_000, 38))  # one result chunk of inverse dynamics on Talos: 3 MB
    t0 = time.perf_counter()
    for _ in range(20):
        ray.get(ray.put(chunk))
    transfer = (time.perf_counter() - t0) / 20
    return {"start": start, "per_task": per_task, "transfer_3mb": transfer}


def report(sims, ids, ray_cost, cores) -> str:
    L = ["# Scaling out (`python -m benchmarks.scale`)", "",
         f"{cores} cores; efficiency = ideal time (single-core time x N / cores) / measured wall time.", ""]
    for title, r, unit in ((f"{sims['n']} Panda simulations (PD, 1 s)", sims, "runs/s"),
                           (f"{ids['n']:,} Talos inverse-dynamics states", ids, "states/s")):
        L += [f"## {title}: single core {r['single'] * 1e6:.1f} us per item", "",
              f"| engine | wall (s) | throughput ({unit}) | efficiency |", "|---|---:|---:|---:|"]
        for row in r["rows"]:
            L.append(f"| {row['engine']} | {row['wall']:.2f} | {row['throughput']:,.0f} | {row['efficiency']:.2f} |")
        L.append("")
    L += ["map_batches does not offer local processes for batches (it runs them on threads, with a warning): the "
          "batched kernels release the GIL, and processes pickled every chunk both ways (0.14 efficiency).", ""]
    L += ["## Ray", "", f"start-up of a local Ray: {ray_cost['start']:.1f} s; per task: "
          f"{ray_cost['per_task'] * 1e3:.2f} ms; one 3 MB result through the object store: "
          f"{ray_cost['transfer_3mb'] * 1e3:.2f} ms", ""]
    L += projection(sims, ids, ray_cost, cores)
    return "\n".join(L) + "\n"


def projection(sims, ids, ray_cost, cores):
    """What N machines of this kind would give, from the measured per-item and per-task costs."""
    L = ["## On paper: N machines of this kind", "",
         "| machines | simulations/s | ID states/s | what limits it |", "|---:|---:|---:|---|"]
    sim_rate = cores / sims["single"]
    id_rate = cores / ids["single"]
    driver_tasks = 1.0 / max(ray_cost["per_task"], 1e-6)  # tasks/s one driver can hand out
    bytes_per_state = ids["nv"] * 8 * 4  # q, v, a in and tau out, float64
    link = 1.25e9  # 10 Gbit/s to the driver
    for n in (1, 4, 16, 64):
        s = n * sim_rate
        i_compute = n * id_rate
        i_net = link / bytes_per_state
        i = min(i_compute, i_net)
        limit = "compute" if i_compute < i_net else "network to the driver (inputs and results)"
        if s / 50 > driver_tasks:  # 50 runs per chunk
            limit += "; task dispatch"
        L.append(f"| {n} | {s:,.0f} | {i:,.0f} | {limit} |")
    L += ["", "Simulations carry little data (a trajectory of 100 samples x 9 joints is ~20 KB), so they scale "
          "with machines until one driver's task dispatch (~1 ms per task) or the job database's writes "
          "(one row per chunk) limit it; larger chunks push that out. Inverse dynamics moves ~1.2 KB per state "
          "(Talos, in and out), so beyond a few machines the driver's network link limits it: generate inputs "
          "on the workers (or keep them in the object store) and reduce results there.", ""]
    return L


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="1,000 simulations and 1 M states (minutes, not tens)")
    p.add_argument("--sims", type=int, default=None)
    p.add_argument("--states", type=int, default=None)
    p.add_argument("--simulations-only", action="store_true",
                   help="only the simulations, on threads: single core against simulate_many's threads")
    p.add_argument("--rounds", type=int, default=1, help="rounds of the simulations' measurement (median reported)")
    args = p.parse_args(argv)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    n_sims = args.sims or (1_000 if args.quick else 10_000)
    n_states = args.states or (1_000_000 if args.quick else 10_000_000)
    if args.simulations_only:
        sims = bench_simulations(n_sims, min(100, n_sims), cores, ("threads",), args.rounds)
        row = sims["rows"][0]
        text = (f"{n_sims} Panda simulations (PD, 1 s), {cores} cores: single core {sims['single'] * 1e3:.2f} ms per run; "
                f"threads: efficiency {row['efficiency']:.2f} (rounds: "
                f"{', '.join(f'{e:.2f}' for e in row['efficiencies'])}), {row['efficiency'] * cores:.2f}x one core "
                f"(not scaled by the runs' work: {row['unscaled']:.2f})\n")
        print(text)
        return 0
    ray_cost = bench_ray_overheads(cores)
    sims = bench_simulations(n_sims, min(100, n_sims), cores, rounds=args.rounds)
    ids = bench_inverse_dynamics(n_states, cores)
    text = report(sims, ids, ray_cost, cores)
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
