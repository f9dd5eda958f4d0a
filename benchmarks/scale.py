"""Scaling out (issue: beyond one machine): `python -m benchmarks.scale [--quick] [--rounds R] [--simulations-only]`.

In one run, on this machine:

* simulations: N Panda runs (PD towards random targets from random states, 1 s, the default integrator)
  through ``dynamics.simulate_many`` with engine="threads", "processes" and "ray" (a local Ray with the
  machine's CPUs), against the ideal = single-core time per run x N / cores (measured on a sample of runs
  on one thread, scaled to the N runs by their right-hand-side evaluations);
* inverse dynamics: S Talos states (floating base, nv = 38) through ``dynamics.map_batches`` on threads and Ray
  (it runs "processes" on threads),
  in blocks of 1 M states (inputs are generated per block: 10 M states of q, v, a are ~9 GB);
* Ray's start-up time and its per-task overhead (empty tasks), and the cost of moving one chunk's result;
* the machine's own ceiling for the simulations, alternated with the threads in each round: the same N runs in
  ``cores`` fresh single-threaded processes (no GIL shared) started at once, each taking the next run as it frees
  up, and (with --simulations-only) one fresh process running all N alone.

From the measured per-chunk costs it derives what N machines would give, and where the bottleneck moves
(printed under the tables).  Tables go to stdout and benchmarks/out/scale.md.
"""

from __future__ import annotations

import argparse
import fcntl
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import dynamics
from dynamics import engines, parallel
from dynamics.torques import PD

OUT = Path(__file__).resolve().parent / "out" / "scale.md"
ROOT = Path(__file__).resolve().parent.parent
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


def bench_simulations(n, sample, cores, engines_=engines.ENGINES, rounds=1, ceiling=True, solo=False):
    """Per round, alternately: ``sample`` runs one after the other on this thread (the single-core time), then the
    N runs through simulate_many on each engine; efficiency per round against that round's single-core time (a
    shared machine's load moves both alike), the median over rounds reported.

    The runs differ in length (3-20 ms: the steps each needs), so the sample's time is scaled to the N runs by
    their right-hand-side evaluations (the same on every engine: the runs are bit-identical): ideal = sample time
    x (evaluations of the N runs / evaluations of the sample) / cores.  (The first 100 of benchmarks' 1,000 runs
    need 1.7 % fewer evaluations than the 1,000 on average; unscaled, that read as 1.7 % of lost efficiency.)

    ``ceiling``: in each round, next to the engines (after them in the first round, before them in the second, ...),
    the same N runs in ``cores`` fresh processes, each single-threaded and sharing no GIL, started at once and taking
    the next run as they free up: what this machine allows CPU-bound processes, against the same ideal.  (A fixed split,
    runs k mod 2, left the larger half 2.1 % more work than an equal share on the 1,000 runs; the threads balance
    as they go.)  ``solo``: one fresh process runs all N one after the other, to check that the sample's scaled
    time is a fresh process's, and to give the processes' ceiling against it (no sample needed)."""
    model = panda()
    rng = np.random.default_rng(0)
    q0, pds = sim_inputs(model, n, rng)
    v0 = np.zeros(model.nv)
    opts = dict(error_estimate="none", sample_dt=0.01, progress=False)
    dynamics.simulate(model, q0[0], v0, 1.0, torque=pds[0], **opts)  # first call
    singles, per_engine, ceilings = [], {engine: [] for engine in engines_}, []
    for r in range(rounds):
        load = os.getloadavg()[0]
        c0, t0 = time.process_time(), time.perf_counter()
        work = 0
        for k in range(sample):
            work += dynamics.simulate(model, q0[k], v0, 1.0, torque=pds[k], **opts).report["rhs_evals"]
        single = (time.perf_counter() - t0) / sample
        single_cpu = (time.process_time() - c0) / sample
        singles.append(single)
        measured, evals = {}, None
        order = (["ceiling"] if ceiling and r % 2 else []) + list(engines_)
        order += ["ceiling"] if ceiling and not r % 2 else []
        for engine in order:
            if engine == "ceiling":
                measured[engine] = _in_processes(n, cores)
                continue
            steal0, c0, t0 = _cpu_stat(), time.process_time(), time.perf_counter()
            out = dynamics.simulate_many(model, q0, v0, 1.0, torque=pds, engine=engine, **opts)
            wall = time.perf_counter() - t0
            measured[engine] = {"wall": wall, "cpu": time.process_time() - c0, "steal": _steal(steal0, wall)}
            assert out.ok.all(), [r["status"] for r in out.reports if r["status"] != "ok"][:3]
            evals = [r["rhs_evals"] for r in out.reports]
        if evals is None:  # no engine measured: the processes' counts (the same runs)
            evals = measured["ceiling"]["evals"]
        one_core = single * sample * sum(evals) / work  # the N runs' time on one core, from the sample
        for engine in engines_:
            m = measured[engine]
            per_engine[engine].append((m["wall"], one_core / cores / m["wall"], single * n / cores / m["wall"]))
        if ceiling:
            m = measured["ceiling"]
            assert m["evals"] == evals  # the processes ran the runs the engines ran, bit for bit
            c = {"load": load, "single": single, "single_cpu": single_cpu, "one_core": one_core, "threads": None,
                 "ceiling": one_core / cores / m["wall"], "pair": m,
                 "first": "ceiling" if r % 2 else "+".join(engines_),
                 "runs_per_process": [q["count"] for q in m["parts"]]}
            if "threads" in measured:
                c["threads"] = per_engine["threads"][-1][1]
                c["threads_m"] = measured["threads"]
            if solo:
                c["solo"] = _in_processes(n, 1)
                assert c["solo"]["evals"] == evals
            ceilings.append(c)
    rows = []
    for engine, rs in per_engine.items():
        wall = float(np.median([r[0] for r in rs]))
        effs = [r[1] for r in rs]
        rows.append({"engine": engine, "wall": wall, "throughput": n / wall, "efficiency": float(np.median(effs)),
                     "efficiencies": effs, "unscaled": float(np.median([r[2] for r in rs]))})
    return {"n": n, "single": float(np.median(singles)), "rows": rows, "ceilings": ceilings, "cores": cores}


def _in_processes(n, processes):
    """The N runs in ``processes`` fresh Python processes, each single-threaded: every process builds the same inputs
    (``sim_inputs``, seed 0), warms up, says it is ready, and from the moment it reads "go" (sent to all at once)
    takes the next run from a shared counter (a file under a lock, as the threads take the next chunk) until none is
    left.  Returns the slowest process's time (the wall time of the whole), the processes' CPU time, each
    process's own figures, every run's evaluations (by run), and the machine's steal over the measurement."""
    env = dict(os.environ, DYNAMICS_NUM_THREADS="1")
    with tempfile.TemporaryDirectory() as tmp:
        counter = Path(tmp) / "next_run"
        counter.write_bytes((0).to_bytes(8, "little"))
        procs = [subprocess.Popen([sys.executable, "-m", "benchmarks.scale", "--worker", str(n), str(counter)],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env, cwd=ROOT)
                 for _ in range(processes)]
        try:
            for p in procs:
                line = p.stdout.readline()
                if line.strip() != "ready":
                    raise RuntimeError(f"benchmark worker failed before its runs (exit {p.wait()}): {line!r}")
            steal0, t0 = _cpu_stat(), time.perf_counter()
            for p in procs:
                p.stdin.write("go\n")
                p.stdin.flush()
            parts = [json.loads(p.stdout.readline()) for p in procs]
            steal = _steal(steal0, time.perf_counter() - t0)
        finally:
            for p in procs:
                p.stdin.close()
                p.wait()
    evals = [None] * n
    for part in parts:
        for k, e in part.pop("runs"):
            assert evals[k] is None, f"run {k} twice"
            evals[k] = e
    assert None not in evals, "a run left out"
    return {"wall": max(q["wall"] for q in parts), "cpu": sum(q["cpu"] for q in parts), "parts": parts,
            "evals": evals, "steal": steal}


def _worker(n, counter):
    """One process of ``_in_processes``: the next run from ``counter`` (8 bytes, locked while read and bumped)."""
    model = panda()
    q0, pds = sim_inputs(model, n, np.random.default_rng(0))
    v0 = np.zeros(model.nv)
    opts = {"error_estimate": "none", "sample_dt": 0.01, "progress": False}  # as bench_simulations'
    for k in range(min(5, n)):  # warm-up: the first call, and caches
        dynamics.simulate(model, q0[k], v0, 1.0, torque=pds[k], **opts)
    fd = os.open(counter, os.O_RDWR)
    print("ready", flush=True)
    sys.stdin.readline()
    c0, t0 = time.process_time(), time.perf_counter()
    runs = []
    while True:
        fcntl.flock(fd, fcntl.LOCK_EX)
        k = int.from_bytes(os.pread(fd, 8, 0), "little")
        os.pwrite(fd, (k + 1).to_bytes(8, "little"), 0)
        fcntl.flock(fd, fcntl.LOCK_UN)
        if k >= n:
            break
        runs.append((k, dynamics.simulate(model, q0[k], v0, 1.0, torque=pds[k], **opts).report["rhs_evals"]))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    os.close(fd)
    print(json.dumps({"wall": wall, "cpu": cpu, "count": len(runs), "runs": runs}), flush=True)


def _cpu_stat():
    """The machine's CPU counters (/proc/stat, ticks): total and steal (time the hypervisor gave elsewhere)."""
    try:
        with open("/proc/stat") as f:
            ticks = [int(x) for x in f.readline().split()[1:]]
    except OSError:
        return None
    return sum(ticks[:8]), ticks[7]


def _steal(before, wall):
    """Steal as a share of the machine's CPU time since ``before`` (None where /proc/stat is not there)."""
    after = _cpu_stat()
    if before is None or after is None or after[0] == before[0]:
        return None
    return (after[1] - before[1]) / (after[0] - before[0])


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
    L += ceiling_table(sims)
    L += projection(sims, ids, ray_cost, cores)
    return "\n".join(L) + "\n"


def ceiling_table(sims):
    """Per round: the threads' efficiency, the machine's ceiling (the same runs in ``cores`` processes sharing no
    GIL), their ratio, and what the machine did meanwhile."""
    cs = sims["ceilings"]
    if not cs:
        return []
    cores, solo = sims["cores"], any("solo" in c for c in cs)
    note = (f"Each round: the single-core sample, then threads and {cores} fresh single-threaded processes (started "
            "at once after their warm-up, each taking the next run as it frees up, as the threads do), in the order "
            "given; both against the same "
            "ideal (the sample's time scaled to the N runs / cores). CPU/wall: CPU seconds the measurement got per "
            "second (threads: the whole process; processes: their sum over the slowest one's time); steal: the "
            "machine's CPU time the hypervisor gave elsewhere meanwhile."
            + (f" Last, one fresh process runs all N alone: its time against the sample's scaled time, and the "
               f"{cores} processes against it (its time / {cores} / theirs), which needs no sample." if solo else ""))
    head = ["round", "first", "load (1 min)", "single core: ms/run (CPU/wall)", "threads", "processes (ceiling)",
            "threads / ceiling", "CPU/wall threads", "CPU/wall processes", "steal % threads / processes"]
    if solo:
        head += ["one fresh process, all N / sample's scaled time", "processes against that one alone"]
    L = [f"## The machine's ceiling: {sims['n']} Panda simulations in {cores} processes sharing no GIL", "", note, "",
         "| " + " | ".join(head) + " |", "|---:|---|" + "---:|" * (len(head) - 2)]
    for i, c in enumerate(cs, 1):
        t, m, tm = c["threads"], c["pair"], c.get("threads_m")
        single = f"{c['single'] * 1e3:.2f} ({c['single_cpu'] / c['single']:.2f})"
        cells = [str(i), c["first"], f"{c['load']:.2f}", single,
                 _fmt(t), f"{c['ceiling']:.2f}",
                 _fmt(t and t / c["ceiling"]), _fmt(tm and tm["cpu"] / tm["wall"]), f"{m['cpu'] / m['wall']:.2f}",
                 f"{_pct(tm and tm['steal'])} / {_pct(m['steal'])}"]
        if solo:
            solo_wall = c["solo"]["wall"]
            cells += [f"{solo_wall / c['one_core']:.3f}", f"{solo_wall / cores / c['pair']['wall']:.2f}"]
        L.append("| " + " | ".join(cells) + " |")
    med = ceiling_medians(sims)
    L += ["", (f"Medians over {len(cs)} rounds: threads {_fmt(med['threads'])} ({_fmt(med['threads'], cores)}x one "
               f"core), the {cores} processes' ceiling {med['ceiling']:.2f} ({med['ceiling'] * cores:.2f}x), threads / "
               f"ceiling {_fmt(med['ratio'])}.")
          + (f" The {cores} processes against one alone: "
             f"{np.median([c['solo']['wall'] / cores / c['pair']['wall'] for c in cs]):.2f}." if solo else ""), ""]
    return L


def _pct(x):
    return "-" if x is None else f"{100 * x:.1f}"


def ceiling_medians(sims):
    cs = sims["ceilings"]
    ts = [c["threads"] for c in cs if c["threads"] is not None]
    return {"threads": float(np.median(ts)) if ts else None,
            "ceiling": float(np.median([c["ceiling"] for c in cs])),
            "ratio": float(np.median([c["threads"] / c["ceiling"] for c in cs])) if ts else None}


def _fmt(x, times=1):
    return "-" if x is None else f"{x * times:.2f}"


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
    p.add_argument("--no-ceiling", action="store_true",
                   help="skip the machine's ceiling (the same runs in one single-threaded process per core)")
    p.add_argument("--worker", nargs=2, metavar=("N", "COUNTER"), help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:  # one process of the ceiling's measurement
        _worker(int(args.worker[0]), args.worker[1])
        return 0
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    n_sims = args.sims or (1_000 if args.quick else 10_000)
    n_states = args.states or (1_000_000 if args.quick else 10_000_000)
    if args.simulations_only:
        sims = bench_simulations(n_sims, min(100, n_sims), cores, ("threads",), args.rounds,
                                 ceiling=not args.no_ceiling, solo=not args.no_ceiling)
        row = sims["rows"][0]
        text = (f"{n_sims} Panda simulations (PD, 1 s), {cores} cores: single core {sims['single'] * 1e3:.2f} ms per run; "
                f"threads: efficiency {row['efficiency']:.2f} (rounds: "
                f"{', '.join(f'{e:.2f}' for e in row['efficiencies'])}), {row['efficiency'] * cores:.2f}x one core "
                f"(not scaled by the runs' work: {row['unscaled']:.2f})\n")
        if sims["ceilings"]:
            med = ceiling_medians(sims)
            each = ", ".join(f"{c['ceiling']:.2f}" for c in sims["ceilings"])
            text += (f"machine's ceiling ({cores} processes, no GIL shared): efficiency {med['ceiling']:.2f} (rounds: "
                     f"{each}), {med['ceiling'] * cores:.2f}x "
                     f"one core; threads / ceiling {med['ratio']:.2f}\n\n")
            text += "\n".join(ceiling_table(sims)) + "\n"
        OUT.parent.mkdir(exist_ok=True)
        OUT.write_text(f"# Scaling out (`python -m benchmarks.scale --simulations-only`)\n\n{text}")
        print(text)
        return 0
    ray_cost = bench_ray_overheads(cores)
    sims = bench_simulations(n_sims, min(100, n_sims), cores, rounds=args.rounds, ceiling=not args.no_ceiling)
    ids = bench_inverse_dynamics(n_states, cores)
    text = report(sims, ids, ray_cost, cores)
    OUT.parent.mkdir(exist_ok=True)
    OUT.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
