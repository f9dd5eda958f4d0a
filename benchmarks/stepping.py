"""Stepping from the caller's loop: ``dynamics.Simulator.step`` against MuJoCo's ``mj_step`` and ``mujoco.rollout``.

Two tables, each measured alternately in one run (the machine is shared; the medians of the rounds are kept):

* **One step from Python, Panda** (example-robot-data's URDF; MuJoCo's own URDF compiler on the same file, visuals
  and collisions stripped, limits, contact and equalities off).  Both hold a PD law to a posture (ours: the
  ``PD`` torque source; MuJoCo: joint springs and damping, inside every stage) and a torque set by the loop before
  each step (ours: ``step(tau)``; MuJoCo: ``qfrc_applied``).  A 1 ms control period: our ``rk4`` with one substep of
  1 ms against ``mj_step`` with MuJoCo's RK4 and a 1 ms timestep, our ``euler`` (symplectic) against its Euler.
* **Go1 standing, 1,000 environments, 2 ms period, 2 threads** (the contact benchmark's quadruped scene,
  :mod:`benchmarks.contact`): our ``Simulator`` with N = 1000 stepped together against ``mujoco.rollout`` of the
  same 1,000 initial states with one MjData per thread; environment-steps per second over 0.1 s simulated, and
  each tool's error on the sum of the foot forces over m g at the end (the same observable as the contact
  benchmark's; 1.0 is exact at rest).

Run: ``python -m benchmarks.stepping [--rounds 5] [--steps 2000] [--envs 1000] [--skip-go1]``; writes
``benchmarks/out/stepping.md``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
OUT = REPO / "benchmarks" / "out"


def panda():
    import dynamics
    from benchmarks.contact import erd
    path = erd("panda_description/urdf/panda.urdf")
    model = dynamics.load_urdf(path, mimic="independent")
    urdf = Path(path).read_text()
    q0 = np.array([0.1, -0.4, 0.2, -2.0, 0.1, 1.6, 0.7, 0.02, 0.02])
    return model, urdf, q0


def mujoco_panda(urdf, model, q_target, kp, kd, integrator, dt):
    from benchmarks.work_precision import mujoco_from_urdf
    return mujoco_from_urdf(urdf, {"rk4": "RK4", "euler": "Euler"}[integrator], dt, (q_target, kp, kd),
                            model.damping, strip_mimic=True)


def single_step_table(rounds, steps):
    import mujoco

    import dynamics
    model, urdf, q0 = panda()
    kp, kd, dt = 50.0, 5.0, 1e-3
    q_target = q0 + 0.2
    tau = np.linspace(-0.5, 0.5, model.nv)
    rows = []
    for integrator in ("rk4", "euler"):
        sim = dynamics.Simulator(model, q0, np.zeros(model.nv), dt=dt, integrator=integrator,
                                 torque=dynamics.torques.PD(kp=kp, kd=kd, q_target=q_target))
        m = mujoco_panda(urdf, model, q_target, kp, kd, integrator, dt)
        d = mujoco.MjData(m)
        d.qpos[:] = q0

        def ours():
            sim.reset()
            tic = time.perf_counter()
            for _ in range(steps):
                sim.step(tau)
                sim.q
            return (time.perf_counter() - tic) / steps

        def theirs():
            mujoco.mj_resetData(m, d)
            d.qpos[:] = q0
            tic = time.perf_counter()
            for _ in range(steps):
                d.qfrc_applied[:] = tau
                mujoco.mj_step(m, d)
                d.qpos
            return (time.perf_counter() - tic) / steps

        ours(), theirs()  # warm
        a, b = [], []
        for _ in range(rounds):
            a.append(ours())
            b.append(theirs())
        # the same physics: both end near the same state after `steps` periods (PD + the held torque)
        sim.reset()
        mujoco.mj_resetData(m, d)
        d.qpos[:] = q0
        for _ in range(200):
            sim.step(tau)
            d.qfrc_applied[:] = tau
            mujoco.mj_step(m, d)
        gap = float(np.abs(sim.q - d.qpos).max())
        ua, ub = statistics.median(a) * 1e6, statistics.median(b) * 1e6
        rows.append((integrator, ua, ub, ua / ub, gap))
    return rows


def _mujoco_go1(scene, dt, X0, nstep, datas):
    import mujoco
    from mujoco import rollout

    from benchmarks.contact import mujoco_model
    m = mujoco_model(scene, dt)
    tic = time.perf_counter()
    states, _ = rollout.rollout(m, datas if datas else mujoco.MjData(m), X0, nstep=nstep)
    return time.perf_counter() - tic, m, states


def _mujoco_force(m, x):
    """sum of the normal contact forces over m g at the state x (MuJoCo's FULLPHYSICS state)."""
    import mujoco
    d = mujoco.MjData(m)
    mujoco.mj_setState(m, d, x, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    mujoco.mj_forward(m, d)
    force, total = np.zeros(6), 0.0
    for i in range(d.ncon):
        mujoco.mj_contactForce(m, d, i, force)
        total += force[0]
    return total


#: our settings in the Go1 table: the accurate default and two fixed-step ones at MuJoCo's error level
GO1_OURS = (("auto, rtol 1e-3", dict(rtol=1e-3, atol=1e-5)), ("rk4, 2 ms", dict(integrator="rk4")),
            ("euler, 0.5 ms substeps", dict(integrator="euler", substep=5e-4)),
            ("implicit_euler, 2 ms", dict(integrator="implicit_euler")))
#: environments whose end state is compared with each tool's converged answer
CHECKED = 10


def go1_table(envs, rounds, seconds=0.2):
    """Go1 released standing (the contact benchmark's scene), every environment but the first with its leg joints
    moved by up to 0.02 rad.  Error: the largest |sum Fn / m g - its converged value| at the end over the first
    CHECKED environments, against each tool's own converged answer (ours at rtol 1e-8, MuJoCo at a 0.1 ms step)."""
    import mujoco

    import dynamics
    from benchmarks.contact import (mujoco_initial_state, mujoco_model, ours_contact, ours_initial, ours_model,
                                    ours_torque, quadruped_scene)
    scene = quadruped_scene()
    dt = 2e-3
    nstep = int(round(seconds / dt))
    model = ours_model(scene)
    contact = ours_contact(scene)
    q0, v0 = ours_initial(scene, model)
    torque = ours_torque(scene, model, q0)
    rng = np.random.default_rng(0)
    Q0 = np.repeat(q0[None], envs, axis=0)
    Q0[1:, 7:] += rng.uniform(-0.02, 0.02, (envs - 1, model.nq - 7))
    weight = scene.mass * 9.81
    k = min(CHECKED, envs)

    def ours_forces(sim):
        return np.array([sim.contact_forces(i, details=True)[1].normal_force.sum() / weight for i in range(k)])

    ref = dynamics.Simulator(model, Q0[:k], v0, dt=dt, torque=torque, contact=contact, rtol=1e-8, atol=1e-10)
    for _ in range(nstep):
        ref.step()
    f_ref = ours_forces(ref)

    m = mujoco_model(scene, dt)
    X0 = np.repeat(mujoco_initial_state(scene, m)[None], envs, axis=0)
    joints = [m.joint(name).qposadr[0] for name in scene.joints0]  # (state: time, then qpos)
    ours_joints = [model.q_index[model.joint_names.index(name)] for name in scene.joints0]
    X0[:, 1 + np.array(joints)] = Q0[:, ours_joints]
    _, m_ref, states_ref = _mujoco_go1(scene, 1e-4, X0[:k], int(round(seconds / 1e-4)), None)
    fm_ref = np.array([_mujoco_force(m_ref, states_ref[i, -1]) for i in range(k)]) / weight
    datas = [mujoco.MjData(m) for _ in range(2)]
    sims = {label: dynamics.Simulator(model, Q0, v0, dt=dt, torque=torque, contact=contact, **kw)
            for label, kw in GO1_OURS}

    def ours(sim):
        sim.reset()
        tic = time.perf_counter()
        for _ in range(nstep):
            sim.step()
        return time.perf_counter() - tic

    times = {label: [] for label in sims}
    times["MuJoCo"] = []
    for _ in range(rounds):
        for label, sim in sims.items():
            times[label].append(ours(sim))
        t, m2, states = _mujoco_go1(scene, dt, X0, nstep, datas)
        times["MuJoCo"].append(t)
    rows = []
    for label, sim in sims.items():
        err = float(np.max(np.abs(ours_forces(sim) - f_ref))) if not sim.failed[:k].any() else float("inf")
        rows.append((f"ours {label}", envs * nstep / statistics.median(times[label]), err,
                     int(np.count_nonzero(sim.failed))))
    fm = np.array([_mujoco_force(m2, states[i, -1]) for i in range(k)]) / weight
    rows.append(("MuJoCo rollout, Euler 2 ms", envs * nstep / statistics.median(times["MuJoCo"]),
                 float(np.max(np.abs(fm - fm_ref))), 0))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--envs", type=int, default=1000)
    ap.add_argument("--skip-go1", action="store_true")
    args = ap.parse_args(argv)
    lines = ["| Panda, 1 ms period | ours (us/step) | MuJoCo mj_step (us/step) | ours / MuJoCo | max abs q gap after 0.2 s |",
             "|---|---|---|---|---|"]
    for integrator, ua, ub, r, gap in single_step_table(args.rounds, args.steps):
        lines.append(f"| {integrator} | {ua:.1f} | {ub:.1f} | {r:.2f}x | {gap:.1e} |")
    if not args.skip_go1:
        rows = go1_table(args.envs, max(1, args.rounds // 2))
        mj = rows[-1][1]
        lines += ["", f"| Go1 standing, {args.envs} environments, 2 ms period, 2 threads | environment-steps/s | "
                  f"vs MuJoCo | error of sum Fn / m g at 0.2 s | failed |", "|---|---|---|---|---|"]
        for label, rate, err, failed in rows:
            lines.append(f"| {label} | {rate:,.0f} | {rate / mj:.2f}x | {err:.1e} | {failed} |")
    text = "\n".join(lines)
    print(text)
    OUT.mkdir(exist_ok=True)
    (OUT / "stepping.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
