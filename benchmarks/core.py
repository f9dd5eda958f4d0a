"""Core benchmarks (issue 2, section 5): `python -m benchmarks.core`.

Per robot (Panda, UR5 and Talos from example-robot-data, found at run time through the installed
package, never copied; a generated 200-link chain), in one run:

* batched per-state time on B states (default 10,000) of inverse dynamics, forward dynamics and the
  mass matrix, as ratios to Pinocchio's `rneaInParallel` / `abaInParallel` with 2 threads (one
  `pin.ModelPool`) and to a Python loop over `pin.crba` (Pinocchio has no batched CRBA);
* single-call latency of `inverse_dynamics`, `forward_dynamics`, `mass_matrix`, `gravity_torques` and
  `bias_forces` as ratios to one call from Python of `pin.rnea`, `pin.aba`, `pin.crba`,
  `pin.computeGeneralizedGravity` and `pin.nonLinearEffects` (Panda, UR5, Talos);
* cold start in a fresh subprocess (import, load_urdf, first calls) with the numba cache warm and
  with NUMBA_CACHE_DIR pointed at an empty temporary directory;
* cold start of the simulation (2R arm), each case in a fresh interpreter with an empty numba cache:
  import + load_urdf + first inverse_dynamics, then the first default simulate, then the first rk4 one
  (``--sim-cold-only`` runs just this table);
* ``--single-only``: just the single-call table (Panda, UR5, Talos), a minute instead of many: the way to
  compare two checkouts run alternately (the script imports the ``dynamics`` its interpreter has installed, so
  ``other/.venv/bin/python benchmarks/core.py --single-only`` times that checkout's library; the header names it);
* cost growth: per-state time of batched RNEA and ABA on chains of 20, 200 and 1000 links.

Ratios are ours / Pinocchio's: below 1.0 we are faster.  Every timing is the best of --repeat runs
(the machine is shared, so the minimum is the least disturbed measurement), and the two sides of a
ratio are measured alternately so that both see the same load.  Before timing, each
robot's results are compared with Pinocchio's on a few states (the "check" column: max relative
difference), so both sides compute the same thing.  The tables are printed and written to
benchmarks/out/core.md (git-ignored).
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import os
import platform
import subprocess
import sys
import tempfile
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

# Pinocchio's *InParallel pools are OpenMP: by default libgomp's idle threads spin after each parallel call,
# and measured alternately with them our batch ran on cores they were spinning on (Panda's batched forward
# dynamics 1.06 us per state against 0.63 alone). Idle OpenMP threads sleep instead; Pinocchio's own times
# are the same either way (abaInParallel 0.87 us per Panda state both ways).
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

import numpy as np  # noqa: E402

OUT = Path(__file__).resolve().parent / "out" / "core.md"
PIN_THREADS = 2
M_BATCH_BYTES = 400 * 2**20
#: Pinocchio's Data grows faster than linearly with the joint count (~0.5 GB at 200 joints, a
#: MemoryError under 8 GB at 1000), so the growth table compares with it only up to this size.
PIN_MAX_JOINTS = 200


# ---------------------------------------------------------------------------------------------
# Robots
# ---------------------------------------------------------------------------------------------


def erd_robots_dir() -> Path:
    """example-robot-data's robots directory, from the installed distribution (never copied)."""
    dist = importlib.metadata.distribution("example-robot-data")
    return Path(dist.locate_file("cmeel.prefix/share/example-robot-data/robots"))


def chain_urdf(n: int, seed: int = 0) -> str:
    """A serial chain of n revolute joints with axes cycling x, y, z, rotated joint origins, offset
    centres of mass and rotated (full) inertia tensors: a generic spatial chain, not a planar one."""
    rng = np.random.default_rng(seed)
    axes = ["1 0 0", "0 1 0", "0 0 1"]
    parts = [f'<robot name="chain{n}">', '<link name="link0"/>']
    for i in range(1, n + 1):
        rpy = " ".join(f"{x:.6f}" for x in rng.uniform(-0.3, 0.3, 3))
        com = " ".join(f"{x:.6f}" for x in rng.uniform(-0.02, 0.02, 2)) + " 0.05"
        m = rng.uniform(0.5, 1.5)
        # a solid box (always a valid inertia), its principal axes turned by a random rotation
        sx, sy, sz = rng.uniform(0.03, 0.12, 3)
        box = m / 12 * np.diag([sy**2 + sz**2, sx**2 + sz**2, sx**2 + sy**2])
        Rb = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        Ib = Rb @ box @ Rb.T
        parts.append(
            f'<joint name="joint{i}" type="revolute"><parent link="link{i - 1}"/>'
            f'<child link="link{i}"/><origin xyz="0 0 0.1" rpy="{rpy}"/>'
            f'<axis xyz="{axes[i % 3]}"/><limit lower="-3.14" upper="3.14" effort="100" velocity="10"/></joint>'
        )
        parts.append(
            f'<link name="link{i}"><inertial><origin xyz="{com}" rpy="0 0 0"/><mass value="{m:.6f}"/>'
            f'<inertia ixx="{Ib[0, 0]:.17g}" ixy="{Ib[0, 1]:.17g}" ixz="{Ib[0, 2]:.17g}" iyy="{Ib[1, 1]:.17g}" '
            f'iyz="{Ib[1, 2]:.17g}" izz="{Ib[2, 2]:.17g}"/></inertial></link>'
        )
    parts.append("</robot>")
    return "\n".join(parts)


@dataclass
class Robot:
    label: str
    source: str  # path or URDF text
    floating_base: bool = False


def benchmark_robots() -> list[Robot]:
    d = erd_robots_dir()
    return [
        Robot("Panda", str(d / "panda_description/urdf/panda.urdf")),
        Robot("UR5", str(d / "ur_description/urdf/ur5_robot.urdf")),
        Robot("Talos (floating)", str(d / "talos_data/robots/talos_full_v2.urdf"), True),
        Robot("chain-200", chain_urdf(200)),
    ]


def load_pinocchio(pin, robot: Robot):
    root = [pin.JointModelFreeFlyer()] if robot.floating_base else []
    if robot.source.lstrip().startswith("<"):
        return pin.buildModelFromXML(robot.source, *root)
    return pin.buildModelFromUrdf(robot.source, *root)


# ---------------------------------------------------------------------------------------------
# States, mapped to Pinocchio's coordinates by joint name
# ---------------------------------------------------------------------------------------------


class PinMap:
    """Maps our (B, nq) / (B, nv) arrays to Pinocchio's, joint by joint (by name).  Continuous
    joints become Pinocchio's (cos, sin) pair; the free-flyer layouts are the same."""

    def __init__(self, model, pm):
        self.model, self.pm = model, pm
        self.q_pairs = []  # (our q slice, pin q index, nq, is_cos_sin)
        self.v_perm = np.empty(pm.nv, dtype=np.int64)  # pin v index -> our v index
        pin_ids = {name: i for i, name in enumerate(pm.names)}
        for j, name in enumerate(model.joint_names):
            # a floating joint inside the URDF keeps its name on both sides; an added root is "root_joint"
            pj = pm.joints[pin_ids[name] if name in pin_ids else pin_ids["root_joint"]]
            qi, vi, nvj = int(model.q_index[j]), int(model.v_index[j]), int(model.nv_joint[j])
            self.q_pairs.append((qi, pj.idx_q, int(model.nq_joint[j]), pj.nq == 2 and pj.nv == 1))
            self.v_perm[pj.idx_v : pj.idx_v + nvj] = np.arange(vi, vi + nvj)

    def q(self, Q):
        out = np.empty((Q.shape[0], self.pm.nq))
        for qi, pqi, nq, cos_sin in self.q_pairs:
            if cos_sin:
                out[:, pqi], out[:, pqi + 1] = np.cos(Q[:, qi]), np.sin(Q[:, qi])
            else:
                out[:, pqi : pqi + nq] = Q[:, qi : qi + nq]
        return out

    def v(self, V):
        return np.ascontiguousarray(V[:, self.v_perm])


def random_states(model, B, rng):
    Q = rng.uniform(-np.pi, np.pi, (B, model.nq))
    for j, kind in enumerate(model.joint_types):
        if kind == "floating":
            k = int(model.q_index[j])
            Q[:, k : k + 3] = rng.uniform(-1, 1, (B, 3))
            quat = rng.normal(size=(B, 4))
            Q[:, k + 3 : k + 7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    V = rng.uniform(-2, 2, (B, model.nv))
    A = rng.uniform(-5, 5, (B, model.nv))
    TAU = rng.uniform(-20, 20, (B, model.nv))
    return Q, V, A, TAU


# ---------------------------------------------------------------------------------------------
# Timing
# ---------------------------------------------------------------------------------------------


def best_time(fn, repeat: int, number: int = 1) -> float:
    """Best (smallest) time of one call over `repeat` runs of `number` calls each, in seconds."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best


def best_pair(fa, fb, repeat: int, number: int = 1) -> tuple[float, float]:
    """best_time of two functions measured alternately, so that both see the same machine load
    (the machine is shared: a ratio of two separately measured minima drifts with the load)."""
    ta = tb = float("inf")
    for _ in range(repeat):
        ta = min(ta, best_time(fa, 1, number))
        tb = min(tb, best_time(fb, 1, number))
    return ta, tb


def rel_diff(a, b) -> float:
    a, b = np.asarray(a), np.asarray(b)
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def load_as_pinocchio(dyn, robot: Robot):
    """Our model of the tree Pinocchio builds: its buildModelFromUrdf ignores <mimic>, so the gripper joints of
    Panda and Talos stay independent here too (with our default mimic="coupling" forward dynamics would be a
    constrained solve, another problem than pin.aba's)."""
    return dyn.load_urdf(robot.source, floating_base=robot.floating_base, mimic="independent")


def bench_robot(dyn, pin, robot: Robot, B: int, repeat: int, rng) -> dict:
    model = load_as_pinocchio(dyn, robot)
    pm = load_pinocchio(pin, robot)
    assert (pm.nv, pm.njoints - 1) == (model.nv, model.nbodies), robot.label
    pmap = PinMap(model, pm)
    Q, V, A, TAU = random_states(model, B, rng)
    # Pinocchio wants (n, B) column-major matrices: the transpose of a C-ordered (B, n) array
    Qp, Vp, Ap, TAUp = pmap.q(Q), pmap.v(V), pmap.v(A), pmap.v(TAU)
    Qc, Vc, Ac, TAUc = Qp.T, Vp.T, Ap.T, TAUp.T
    pool = pin.ModelPool(pm, PIN_THREADS)
    pd = pm.createData()
    out_p = np.zeros((pm.nv, B), order="F")

    # same results on both sides (and the first calls compile / warm everything)
    k = min(B, 5)
    check = 0.0
    tau = dyn.inverse_dynamics(model, Q[:k], V[:k], A[:k])
    acc = dyn.forward_dynamics(model, Q[:k], V[:k], TAU[:k])
    M = dyn.mass_matrix(model, Q[:k])
    for i in range(k):
        check = max(check, rel_diff(pmap.v(tau[i : i + 1])[0], pin.rnea(pm, pd, Qp[i], Vp[i], Ap[i])))
        check = max(check, rel_diff(pmap.v(acc[i : i + 1])[0], pin.aba(pm, pd, Qp[i], Vp[i], TAUp[i])))
        Mp = pin.crba(pm, pd, Qp[i])
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        check = max(check, rel_diff(M[i][np.ix_(pmap.v_perm, pmap.v_perm)], Mp))

    r = {"robot": robot.label, "nq": model.nq, "nv": model.nv, "nbodies": model.nbodies, "check": check, "B": B}
    r["id"], r["id_pin"] = (
        t / B
        for t in best_pair(
            lambda: dyn.inverse_dynamics(model, Q, V, A),
            lambda: pin.rneaInParallel(PIN_THREADS, pool, Qc, Vc, Ac, out_p),
            repeat,
        )
    )
    r["fd"], r["fd_pin"] = (
        t / B
        for t in best_pair(
            lambda: dyn.forward_dynamics(model, Q, V, TAU),
            lambda: pin.abaInParallel(PIN_THREADS, pool, Qc, Vc, TAUc, out_p),
            repeat,
        )
    )
    # (B, nv, nv) output: cap the batch at ~M_BATCH_BYTES (chain-200: 1250 states, not 3.2 GB)
    Bm = r["B_m"] = int(min(B, max(100, M_BATCH_BYTES // (8 * model.nv**2))))
    Qm = Q[:Bm]

    def crba_loop():
        for i in range(Bm):
            pin.crba(pm, pd, Qp[i])

    r["m"], r["m_pin"] = (t / Bm for t in best_pair(lambda: dyn.mass_matrix(model, Qm), crba_loop, repeat))

    r.update(bench_single(dyn, pin, model, pm, pd, (Q[0], V[0], A[0], TAU[0]), (Qp[0], Vp[0], Ap[0], TAUp[0]),
                          repeat))
    r["single"], r["single_pin"] = r["single_id"], r["single_id_pin"]
    return r


#: single-call rows: (key, label, ours, Pinocchio's) with the arguments (q, v, a, tau) each takes
SINGLE_CALLS = [
    ("id", "inverse_dynamics / rnea", lambda dyn, m, q, v, a, t: dyn.inverse_dynamics(m, q, v, a),
     lambda pin, pm, pd, q, v, a, t: pin.rnea(pm, pd, q, v, a)),
    ("fd", "forward_dynamics / aba", lambda dyn, m, q, v, a, t: dyn.forward_dynamics(m, q, v, t),
     lambda pin, pm, pd, q, v, a, t: pin.aba(pm, pd, q, v, t)),
    ("m", "mass_matrix / crba", lambda dyn, m, q, v, a, t: dyn.mass_matrix(m, q),
     lambda pin, pm, pd, q, v, a, t: pin.crba(pm, pd, q)),
    ("g", "gravity_torques / computeGeneralizedGravity", lambda dyn, m, q, v, a, t: dyn.gravity_torques(m, q),
     lambda pin, pm, pd, q, v, a, t: pin.computeGeneralizedGravity(pm, pd, q)),
    ("bias", "bias_forces / nonLinearEffects", lambda dyn, m, q, v, a, t: dyn.bias_forces(m, q, v),
     lambda pin, pm, pd, q, v, a, t: pin.nonLinearEffects(pm, pd, q, v)),
]


def bench_single(dyn, pin, model, pm, pd, ours, theirs, repeat, n_calls=1000) -> dict:
    """One call from Python of each SINGLE_CALLS pair on one state (fresh contiguous float64 vectors, as a
    controller would pass them), timed alternately: best of 3 * repeat runs of n_calls calls."""
    ours = [np.array(x) for x in ours]
    theirs = [np.array(x) for x in theirs]
    r = {}
    for key, _, f_ours, f_pin in SINGLE_CALLS:
        fa = lambda: f_ours(dyn, model, *ours)  # noqa: E731
        fb = lambda: f_pin(pin, pm, pd, *theirs)  # noqa: E731
        fa(), fb()
        r[f"single_{key}"], r[f"single_{key}_pin"] = best_pair(fa, fb, 3 * repeat, n_calls)
    return r


def bench_single_robot(dyn, pin, robot: Robot, repeat: int, rng) -> dict:
    """Only the single-call rows of :func:`bench_robot` (same states: the first of a random batch)."""
    model = load_as_pinocchio(dyn, robot)
    pm = load_pinocchio(pin, robot)
    pmap = PinMap(model, pm)
    Q, V, A, TAU = random_states(model, 1, rng)
    theirs = (pmap.q(Q)[0], pmap.v(V)[0], pmap.v(A)[0], pmap.v(TAU)[0])
    r = {"robot": robot.label}
    r.update(bench_single(dyn, pin, model, pm, pm.createData(), (Q[0], V[0], A[0], TAU[0]), theirs, repeat))
    return r


def bench_growth(dyn, pin, n: int, B: int, repeat: int, rng) -> dict:
    robot = Robot(f"chain-{n}", chain_urdf(n))
    model = dyn.load_urdf(robot.source)
    Q, V, A, TAU = random_states(model, B, rng)
    dyn.inverse_dynamics(model, Q[:2], V[:2], A[:2])
    dyn.forward_dynamics(model, Q[:2], V[:2], TAU[:2])
    ours_id = lambda: dyn.inverse_dynamics(model, Q, V, A)  # noqa: E731
    ours_fd = lambda: dyn.forward_dynamics(model, Q, V, TAU)  # noqa: E731
    r = {"n": n, "B": B, "id_pin": None, "fd_pin": None}
    if n <= PIN_MAX_JOINTS:
        pm = load_pinocchio(pin, robot)
        Qc, Vc, Ac, TAUc = Q.T, V.T, A.T, TAU.T  # chain: same coordinates on both sides
        pool = pin.ModelPool(pm, PIN_THREADS)
        out_p = np.zeros((pm.nv, B), order="F")
        pin_id = lambda: pin.rneaInParallel(PIN_THREADS, pool, Qc, Vc, Ac, out_p)  # noqa: E731
        pin_fd = lambda: pin.abaInParallel(PIN_THREADS, pool, Qc, Vc, TAUc, out_p)  # noqa: E731
        r["id"], r["id_pin"] = (t / B for t in best_pair(ours_id, pin_id, repeat))
        r["fd"], r["fd_pin"] = (t / B for t in best_pair(ours_fd, pin_fd, repeat))
    else:
        r["id"] = best_time(ours_id, repeat) / B
        r["fd"] = best_time(ours_fd, repeat) / B
    return r


COLD_SCRIPT = textwrap.dedent(
    """
    import json, sys, time
    import numpy as np
    t0 = time.perf_counter()
    import dynamics
    t1 = time.perf_counter()
    m = dynamics.load_urdf(sys.argv[1])
    t2 = time.perf_counter()
    q = np.zeros(m.nq); v = np.zeros(m.nv)
    dynamics.inverse_dynamics(m, q, v, v)
    t3 = time.perf_counter()
    dynamics.forward_dynamics(m, q, v, v)
    dynamics.mass_matrix(m, q)
    Q = np.zeros((256, m.nq)); V = np.zeros((256, m.nv))
    dynamics.inverse_dynamics(m, Q, V, V)
    dynamics.forward_dynamics(m, Q, V, V)
    dynamics.mass_matrix(m, Q)
    t4 = time.perf_counter()
    print(json.dumps({"import": t1 - t0, "load": t2 - t1, "first_id": t3 - t2, "all_first": t4 - t0}))
    """
)


def cold_start(urdf: str, cache_dir: str | None) -> dict:
    """Run COLD_SCRIPT in a fresh interpreter; cache_dir = None leaves numba's cache where it is."""
    env = dict(os.environ)
    if cache_dir is None:
        env.pop("NUMBA_CACHE_DIR", None)
    else:
        env["NUMBA_CACHE_DIR"] = cache_dir
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", COLD_SCRIPT, urdf], env=env, capture_output=True, text=True, check=True
    )
    r = json.loads(out.stdout.strip().splitlines()[-1])
    r["process"] = time.perf_counter() - t0
    return r


def bench_cold(urdf: str, repeat: int) -> dict:
    cold_start(urdf, None)  # make sure the default cache is populated
    warm = min((cold_start(urdf, None) for _ in range(repeat)), key=lambda r: r["process"])
    runs = []
    for _ in range(max(1, min(repeat, 2))):  # a cold compile is expensive: at most 2 runs
        with tempfile.TemporaryDirectory(prefix="numba-cold-") as d:
            runs.append(cold_start(urdf, d))
    cold = min(runs, key=lambda r: r["process"])
    return {"warm": warm, "cold": cold}


#: cold start of the simulation (issue 8, section 3): each case in its own interpreter with an empty cache
SIM_COLD_SCRIPT = textwrap.dedent(
    """
    import json, resource, sys, time
    t0 = time.perf_counter()
    import numpy as np
    import dynamics
    arm = dynamics.load_urdf(sys.argv[1])
    dynamics.inverse_dynamics(arm, np.zeros(2), np.zeros(2), np.zeros(2))
    t1 = time.perf_counter()
    if sys.argv[2] == "default":
        dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 1.0)
    elif sys.argv[2] == "rk4":
        dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 1.0, integrator="rk4", dt=1e-3)
    elif sys.argv[2] == "os":
        target = dynamics.torques.Target("tip", [1.2, 0.0, 0.9], kp=100.0, kd=20.0, rows=[0, 2])
        dynamics.simulate(arm, [0.5, 0.2], [0.0, 0.0], 1.0, torque=target, integrator="rk4", dt=1e-3)
    t2 = time.perf_counter()
    cpu = resource.getrusage(resource.RUSAGE_SELF)
    print(json.dumps({"library": t1 - t0, "simulate": t2 - t1, "cpu": cpu.ru_utime + cpu.ru_stime}))
    """
)

SIM_COLD_CASES = (("library", "import + load_urdf + first inverse_dynamics"),
                  ("default", "... + first simulate, default integrator (auto)"),
                  ("rk4", "... + first simulate, integrator='rk4'"),
                  ("os", "... + first simulate, rk4, operational-space torque (Target)"))


def bench_cold_simulation(urdf: str) -> list[dict]:
    """Each case of SIM_COLD_CASES in a fresh interpreter with NUMBA_CACHE_DIR a new empty directory: wall
    seconds of the library part and of the first simulate, and the process's CPU seconds (on a shared,
    loaded machine the CPU time is the steadier figure)."""
    rows = []
    for case, label in SIM_COLD_CASES:
        with tempfile.TemporaryDirectory(prefix="numba-cold-") as d:
            env = dict(os.environ, NUMBA_CACHE_DIR=d)
            out = subprocess.run([sys.executable, "-c", SIM_COLD_SCRIPT, urdf, case], env=env, capture_output=True,
                                 text=True, check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        rows.append(dict(r, case=case, label=label))
    return rows


def sim_cold_table(rows) -> list[str]:
    L = ["## Cold start of the simulation (2R arm, fresh interpreter, empty numba cache)", "",
         "| case | library part (s) | first simulate (s) | total wall (s) | CPU (s) |", "|---|---:|---:|---:|---:|"]
    for r in rows:
        sim = f"{r['simulate']:.1f}" if r["case"] != "library" else "-"
        L.append(f"| {r['label']} | {r['library']:.1f} | {sim} | {r['library'] + r['simulate']:.1f} | {r['cpu']:.1f} |")
    return L + [""]


# ---------------------------------------------------------------------------------------------
# Report
# ---------------------------------------------------------------------------------------------


def us(t):
    return f"{t * 1e6:.2f}"


def machine_header(B, repeat) -> list[str]:
    import numba
    import pinocchio as pin

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "n/a"
    from dynamics.parallel import num_threads

    return [
        f"Machine: {cpu}, {os.cpu_count()} logical CPUs, load average at start {load}.  "
        f"Python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}, "
        f"Pinocchio {pin.__version__}.",
        f"Batched runs: {B} states; our batch uses {num_threads()} threads, Pinocchio {PIN_THREADS} "
        f"(ModelPool).  Every time is the best of {repeat} runs.  Ratio = ours / Pinocchio (< 1: we are faster).",
    ]


def single_table(rows) -> list[str]:
    L = [
        "## Single call from Python (us per call)",
        "",
        "| robot | " + " | ".join(f"{label} | ratio" for _, label, _, _ in SINGLE_CALLS) + " |",
        "|---|" + "---:|---:|" * len(SINGLE_CALLS),
    ]
    for r in rows:
        if "single_id" not in r or r["robot"].startswith("chain"):
            continue
        cells = [f"{us(r[f'single_{k}'])} / {us(r[f'single_{k}_pin'])} | {r[f'single_{k}'] / r[f'single_{k}_pin']:.2f}"
                 for k, _, _, _ in SINGLE_CALLS]
        L.append(f"| {r['robot']} | " + " | ".join(cells) + " |")
    return L + ["", "Target: every single-call ratio <= 1.5 on Panda and UR5.", ""]


def tables(header, rows, growth, cold, cold_robot) -> str:
    L = ["# Core benchmarks (`python -m benchmarks.core`)", ""] + header + [""]
    L += [
        "## Batched, per state (us), and single-call latency",
        "",
        "| robot | nq/nv | ID | rneaInParallel | ratio | FD | abaInParallel | ratio | M | loop of pin.crba | ratio "
        "| one ID call | one pin.rnea | ratio | check |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        L.append(
            f"| {r['robot']} | {r['nq']}/{r['nv']} | {us(r['id'])} | {us(r['id_pin'])} | {r['id'] / r['id_pin']:.2f} "
            f"| {us(r['fd'])} | {us(r['fd_pin'])} | {r['fd'] / r['fd_pin']:.2f} "
            f"| {us(r['m'])} | {us(r['m_pin'])} | {r['m'] / r['m_pin']:.2f} "
            f"| {us(r['single'])} | {us(r['single_pin'])} | {r['single'] / r['single_pin']:.2f} | {r['check']:.0e} |"
        )
    capped = [f"{r['robot']}: {r['B_m']}" for r in rows if r["B_m"] < r["B"]]
    L += [
        "",
        "Targets: batched ratios <= 1.0, single-call ratio <= 1.5.  check = largest relative difference "
        "from Pinocchio over tau, a and M on 5 states.",
    ]
    if capped:
        L.append(f"Mass matrix batches capped at {M_BATCH_BYTES >> 20} MiB of output: " + ", ".join(capped) + " states.")
    L.append("")
    L += single_table(rows)
    if growth:
        base = growth[0]
        L += [
            "## Cost growth on chains (batched, per state)",
            "",
            "| links | states | RNEA (us) | ns/link | pin (us) | ratio | ABA (us) | ns/link | pin (us) | ratio |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        def pin_cols(ours, theirs):
            return "n/a | n/a" if theirs is None else f"{us(theirs)} | {ours / theirs:.2f}"

        for g in growth:
            n = g["n"]
            L.append(
                f"| {n} | {g['B']} | {us(g['id'])} | {g['id'] / n * 1e9:.0f} | {pin_cols(g['id'], g['id_pin'])} "
                f"| {us(g['fd'])} | {g['fd'] / n * 1e9:.0f} | {pin_cols(g['fd'], g['fd_pin'])} |"
            )
        last = growth[-1]
        scale = last["n"] / base["n"]
        L += [
            "",
            f"Linear growth means time x{scale:.0f} from {base['n']} to {last['n']} links: measured "
            f"RNEA x{last['id'] / base['id']:.1f}, ABA x{last['fd'] / base['fd']:.1f}.  "
            f"Pinocchio is not run above {PIN_MAX_JOINTS} joints: its Data grows faster than linearly "
            f"(~0.5 GB at 200 joints; MemoryError under an 8 GB limit at 1000).",
            "",
        ]
    if cold:
        L += [
            f"## Cold start ({cold_robot}, fresh interpreter)",
            "",
            "| numba cache | import dynamics (s) | load_urdf (s) | first inverse_dynamics (s) "
            "| import + first ID, FD, M single and batched (s) | whole process (s) |",
            "|---|---:|---:|---:|---:|---:|",
        ]
        for label, key in [("warm", "warm"), ("empty (NUMBA_CACHE_DIR = new temp dir)", "cold")]:
            c = cold[key]
            L.append(
                f"| {label} | {c['import']:.3f} | {c['load']:.3f} | {c['first_id']:.3f} | {c['all_first']:.3f} "
                f"| {c['process']:.3f} |"
            )
        L.append("")
    return "\n".join(L)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--states", type=int, default=10_000, help="batch size (default 10000)")
    p.add_argument("--repeat", type=int, default=5, help="best of N runs (default 5)")
    p.add_argument("--quick", action="store_true", help="1000 states, best of 2, chains up to 200")
    p.add_argument("--no-cold", action="store_true", help="skip the cold-start subprocesses")
    p.add_argument("--no-growth", action="store_true", help="skip the chain growth table")
    p.add_argument("--sim-cold-only", action="store_true", help="only the simulation cold-start table")
    p.add_argument("--single-only", action="store_true", help="only the single-call table (Panda, UR5, Talos)")
    args = p.parse_args(argv)
    B, repeat = (1000, 2) if args.quick else (args.states, args.repeat)
    arm = str(Path(__file__).resolve().parent.parent / "robots" / "planar_2r.urdf")
    if args.sim_cold_only:
        print("\n".join(sim_cold_table(bench_cold_simulation(arm))))
        return 0

    import pinocchio as pin

    import dynamics as dyn

    rng = np.random.default_rng(0)
    header = machine_header(B, repeat)
    if args.single_only:
        rows = [bench_single_robot(dyn, pin, robot, repeat, rng) for robot in benchmark_robots()[:3]]
        where = Path(dyn.__file__).resolve().parent.parent
        print("\n".join(header[:1] + [f"dynamics from {where}.", ""] + single_table(rows)))
        return 0
    rows = []
    for robot in benchmark_robots():
        print(f"... {robot.label}", file=sys.stderr, flush=True)
        rows.append(bench_robot(dyn, pin, robot, B, repeat, rng))
    growth = []
    if not args.no_growth:
        for n in (20, 200) if args.quick else (20, 200, 1000):
            print(f"... chain of {n}", file=sys.stderr, flush=True)
            growth.append(bench_growth(dyn, pin, n, B if n <= 200 else max(B // 5, 100), repeat, rng))
    cold, cold_robot = None, "Panda"
    if not args.no_cold:
        print("... cold start", file=sys.stderr, flush=True)
        cold = bench_cold(benchmark_robots()[0].source, min(repeat, 3))
    report = tables(header, rows, growth, cold, cold_robot)
    if not args.no_cold:
        print("... cold start of the simulation", file=sys.stderr, flush=True)
        report += "\n" + "\n".join(sim_cold_table(bench_cold_simulation(arm)))
    print(report)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(report + "\n")
    print(f"(written to {OUT})", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
