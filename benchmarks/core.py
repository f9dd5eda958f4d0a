"""Core benchmarks (issue 2, section 5): `python -m benchmarks.core`.

Per robot (Panda, UR5 and Talos from example-robot-data, found at run time through the installed
package, never copied; a generated 200-link chain), in one run:

* batched per-state time on B states (default 10,000) of inverse dynamics, forward dynamics and the
  mass matrix, as ratios to Pinocchio's `rneaInParallel` / `abaInParallel` with 2 threads (one
  `pin.ModelPool`) and to a Python loop over `pin.crba` (Pinocchio has no batched CRBA);
* single-call latency of `inverse_dynamics`, `forward_dynamics`, `mass_matrix`, `gravity_torques` and
  `bias_forces` as ratios to one call from Python of `pin.rnea`, `pin.aba`, `pin.crba`,
  `pin.computeGeneralizedGravity` and `pin.nonLinearEffects` (Panda, UR5, Talos);
* first calls, each in fresh processes (min / median / max over --processes of them, the tools alternated):
  ``import dynamics``, load_urdf of Panda and the first inverse_dynamics, mass_matrix, forward_dynamics and
  frame_jacobian; the first simulate of PUMA (robots/puma560.urdf, default auto); the first contact simulation of
  the README's ball; against Pinocchio's (``import pinocchio``, buildModelFromUrdf, rnea, crba, aba,
  computeFrameJacobian) and MuJoCo's (``import mujoco``, MjModel.from_xml_string of the ball on a plane, an mj_step
  loop) where they have them (``--first-call-only`` runs just this table);
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

    # same results on both sides (and the first calls warm everything)
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


#: First calls in a fresh process (no cache of any kind survives between processes): each script prints the seconds
#: of each step, in order; the parent times the whole process.  Ours in three processes (the kinematics and dynamics
#: calls, the first simulate, the first contact simulation: each a truly first call); Pinocchio's and MuJoCo's in
#: one each.  argv: Panda's URDF, PUMA's URDF.
FIRST_CALL_SCRIPTS = {
    "ours: Panda": textwrap.dedent(
        """
        import json, sys, time
        T = [time.perf_counter()]
        def lap(): T.append(time.perf_counter())
        import numpy as np
        import dynamics; lap()
        m = dynamics.load_urdf(sys.argv[1], mimic="independent"); lap()
        q = m.neutral(); v = np.zeros(m.nv)
        dynamics.inverse_dynamics(m, q, v, v); lap()
        dynamics.mass_matrix(m, q); lap()
        dynamics.forward_dynamics(m, q, v, v); lap()
        dynamics.frame_jacobian(m, q, "panda_hand"); lap()
        d = np.diff(T)
        print(json.dumps(dict(zip(["import", "load_panda", "id", "m", "fd", "jac"], d.tolist()))))
        """),
    "ours: PUMA simulate": textwrap.dedent(
        """
        import json, sys, time
        T = [time.perf_counter()]
        def lap(): T.append(time.perf_counter())
        import numpy as np
        import dynamics; lap()
        m = dynamics.load_urdf(sys.argv[2]); lap()
        dynamics.simulate(m, m.neutral() + 0.1, np.zeros(m.nv), 1.0, progress=False); lap()
        d = np.diff(T)
        print(json.dumps(dict(zip(["import", "load_puma", "sim"], d.tolist()))))
        """),
    "ours: ball contact": textwrap.dedent(
        """
        import json, sys, time
        T = [time.perf_counter()]
        def lap(): T.append(time.perf_counter())
        import numpy as np
        import dynamics; lap()
        BALL = '''<robot name="ball"><link name="ball"><inertial><mass value="0.2"/>
          <inertia ixx="2e-4" iyy="2e-4" izz="2e-4" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>'''
        ball = dynamics.load_urdf(BALL, floating_base=True); lap()
        dynamics.simulate(ball, [0, 0, 0.3, 0, 0, 0, 1], np.zeros(6), 0.6, progress=False,
                          contact=dynamics.Contact(geometries=[dynamics.Sphere("ball", 0.05)])); lap()
        d = np.diff(T)
        print(json.dumps(dict(zip(["import", "load_ball", "contact"], d.tolist()))))
        """),
    "Pinocchio: Panda": textwrap.dedent(
        """
        import json, sys, time
        T = [time.perf_counter()]
        def lap(): T.append(time.perf_counter())
        import numpy as np
        import pinocchio as pin; lap()
        m = pin.buildModelFromUrdf(sys.argv[1]); d = m.createData(); lap()
        q = pin.neutral(m); v = np.zeros(m.nv)
        pin.rnea(m, d, q, v, v); lap()
        pin.crba(m, d, q); lap()
        pin.aba(m, d, q, v, v); lap()
        pin.computeFrameJacobian(m, d, q, m.getFrameId("panda_hand")); lap()
        d = np.diff(T)
        print(json.dumps(dict(zip(["import", "load_panda", "id", "m", "fd", "jac"], d.tolist()))))
        """),
    "MuJoCo: ball contact": textwrap.dedent(
        """
        import json, sys, time
        T = [time.perf_counter()]
        def lap(): T.append(time.perf_counter())
        import numpy as np
        import mujoco; lap()
        XML = '''<mujoco><worldbody><geom type="plane" size="0 0 1"/>
          <body pos="0 0 0.3"><freejoint/><geom type="sphere" size="0.05" mass="0.2"/></body></worldbody></mujoco>'''
        m = mujoco.MjModel.from_xml_string(XML); d = mujoco.MjData(m); lap()
        for _ in range(round(0.6 / m.opt.timestep)):
            mujoco.mj_step(m, d)
        lap()
        d = np.diff(T)
        print(json.dumps(dict(zip(["import", "load_ball", "contact"], d.tolist()))))
        """),
}

#: the first-call table's rows: (key, what, ours, Pinocchio's, MuJoCo's call; None where it has none)
FIRST_CALL_ROWS = (
    ("import", "import", "import dynamics", "import pinocchio", "import mujoco"),
    ("load_panda", "load Panda", "load_urdf", "buildModelFromUrdf + createData", None),
    ("id", "first inverse dynamics", "inverse_dynamics", "rnea", None),
    ("m", "first mass matrix", "mass_matrix", "crba", None),
    ("fd", "first forward dynamics", "forward_dynamics", "aba", None),
    ("jac", "first frame Jacobian (panda_hand)", "frame_jacobian", "computeFrameJacobian", None),
    ("load_puma", "load PUMA 560 (robots/puma560.urdf)", "load_urdf", None, None),
    ("sim", "first simulate of PUMA (1 s, default auto)", "simulate", None, None),
    ("load_ball", "load the README's ball", "load_urdf", None, "MjModel.from_xml_string + MjData"),
    ("contact", "first contact simulation of the ball (0.6 s)", "simulate(contact=...)", None,
     "mj_step loop (its default 2 ms step)"),
    ("process", "whole process (from its start to its exit)", None, None, None),
)


def first_call_process(name: str, panda: str, puma: str) -> dict:
    """One fresh interpreter running FIRST_CALL_SCRIPTS[name]: its steps' seconds and the whole process's."""
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", FIRST_CALL_SCRIPTS[name], panda, puma], capture_output=True,
                         text=True, cwd="/")
    if out.returncode:
        raise RuntimeError(f"{name}: the first-call process failed:\n{out.stderr[-2000:]}")
    r = json.loads(out.stdout.strip().splitlines()[-1])
    r["process"] = time.perf_counter() - t0
    return r


def bench_first_calls(processes: int) -> dict[str, dict[str, list[float]]]:
    """Every script of FIRST_CALL_SCRIPTS ``processes`` times, alternated (round after round), each in a fresh
    process: {tool: {step: [seconds, ...]}} for "ours", "Pinocchio" and "MuJoCo" (a tool whose package cannot be
    found is left out; ours' import and process rows pool its three scripts)."""
    import importlib.util
    panda = str(erd_robots_dir() / "panda_description/urdf/panda.urdf")
    puma = str(Path(__file__).resolve().parent.parent / "robots" / "puma560.urdf")
    names = [n for n in FIRST_CALL_SCRIPTS
             if n.startswith("ours") or importlib.util.find_spec(n.split(":")[0].lower()) is not None]
    out: dict[str, dict[str, list[float]]] = {}
    for _ in range(processes):
        for n in names:
            steps = out.setdefault(n.split(":")[0], {})
            for key, seconds in first_call_process(n, panda, puma).items():
                steps.setdefault(key, []).append(seconds)
    return out


def first_call_table(res: dict[str, dict[str, list[float]]], processes: int) -> list[str]:
    tools = [t for t in ("ours", "Pinocchio", "MuJoCo") if t in res]

    def cell(tool, key):
        xs = res[tool].get(key)
        if not xs:
            return "-"
        xs = np.array(xs) * 1e3
        return " / ".join(f"{x:.0f}" if x >= 100 else f"{x:.3g}" for x in (xs.min(), np.median(xs), xs.max()))
    L = [f"## First calls in a fresh process (ms: min / median / max over {processes} processes each, alternated)",
         "",
         "Ours in three processes (Panda's calls; PUMA's simulate; the ball's contact simulation), each call a first "
         "one; their import and whole-process times pooled.  Pinocchio and MuJoCo in one process each.", "",
         "| step | " + " | ".join(tools) + " | calls (ours; Pinocchio; MuJoCo) |",
         "|---|" + "---:|" * len(tools) + "---|"]
    for key, what, *calls in FIRST_CALL_ROWS:
        names = "; ".join(c or "-" for c in calls) if any(calls) else ""
        L.append(f"| {what} | " + " | ".join(cell(t, key) for t in tools) + f" | {names} |")
    return L + [""]


# ---------------------------------------------------------------------------------------------
# Report
# ---------------------------------------------------------------------------------------------


def us(t):
    return f"{t * 1e6:.2f}"


def machine_header(B, repeat) -> list[str]:
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
        f"Python {platform.python_version()}, numpy {np.__version__}, "
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


def tables(header, rows, growth) -> str:
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
    return "\n".join(L)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--states", type=int, default=10_000, help="batch size (default 10000)")
    p.add_argument("--repeat", type=int, default=5, help="best of N runs (default 5)")
    p.add_argument("--quick", action="store_true", help="1000 states, best of 2, chains up to 200")
    p.add_argument("--no-first-call", action="store_true", help="skip the first-call processes")
    p.add_argument("--processes", type=int, default=None,
                   help="fresh processes per first-call script (default 10, 2 with --quick)")
    p.add_argument("--no-growth", action="store_true", help="skip the chain growth table")
    p.add_argument("--first-call-only", action="store_true", help="only the first-call table")
    p.add_argument("--single-only", action="store_true", help="only the single-call table (Panda, UR5, Talos)")
    args = p.parse_args(argv)
    B, repeat = (1000, 2) if args.quick else (args.states, args.repeat)
    processes = args.processes or (2 if args.quick else 10)
    if args.first_call_only:
        print("\n".join(first_call_table(bench_first_calls(processes), processes)))
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
    report = tables(header, rows, growth)
    if not args.no_first_call:
        print("... first calls", file=sys.stderr, flush=True)
        report += "\n" + "\n".join(first_call_table(bench_first_calls(processes), processes))
    print(report)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(report + "\n")
    print(f"(written to {OUT})", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
