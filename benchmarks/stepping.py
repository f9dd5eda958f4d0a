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
import re
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
    import mujoco
    mujoco.set_mju_user_warning(lambda msg: None)
    txt = re.sub(r"<visual>.*?</visual>|<collision>.*?</collision>", "", urdf, flags=re.S)
    txt = re.sub(r"<mimic[^>]*/>", "", txt)
    txt = txt.replace("</robot>", '<mujoco><compiler discardvisual="true" fusestatic="false" '
                                  'balanceinertia="false"/></mujoco></robot>')
    m = mujoco.MjModel.from_xml_string(txt)
    dis = mujoco.mjtDisableBit
    m.opt.disableflags |= dis.mjDSBL_LIMIT | dis.mjDSBL_CONTACT | dis.mjDSBL_EQUALITY
    m.opt.timestep = dt
    m.opt.integrator = {"rk4": mujoco.mjtIntegrator.mjINT_RK4, "euler": mujoco.mjtIntegrator.mjINT_EULER}[integrator]
    m.jnt_stiffness[:] = kp
    m.qpos_spring[:] = q_target
    m.dof_damping[:] = np.asarray(model.damping) + kd
    return m


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


def go1_table(envs, rounds, seconds=0.1):
    import mujoco
    from mujoco import rollout

    import dynamics
    from benchmarks.contact import (mujoco_model, ours_contact, ours_initial, ours_model, ours_torque,
                                    quadruped_scene)
    scene = quadruped_scene()
    dt = 2e-3
    nstep = int(round(seconds / dt))
    model = ours_model(scene)
    contact = ours_contact(scene)
    q0, v0 = ours_initial(scene, model)
    torque = ours_torque(scene, model, q0)
    rng = np.random.default_rng(0)
    Q0 = np.repeat(q0[None], envs, axis=0)
    Q0[:, 2] += 0.01 * rng.random(envs)  # released from slightly different heights
    sim = dynamics.Simulator(model, Q0, v0, dt=dt, torque=torque, contact=contact, rtol=1e-3, atol=1e-5)

    m = mujoco_model(scene, dt)
    d = mujoco.MjData(m)
    d.qpos[:3], d.qpos[3:7] = scene.p0, scene.quat0
    for name, value in scene.joints0.items():
        d.qpos[m.joint(name).qposadr[0]] = value
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    x = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, x, spec)
    X0 = np.repeat(x[None], envs, axis=0)
    X0[:, 1 + 2] += Q0[:, 2] - q0[2]  # (state: time, then qpos)
    datas = [mujoco.MjData(m) for _ in range(2)]

    def ours():
        sim.reset()
        tic = time.perf_counter()
        for _ in range(nstep):
            sim.step()
        return time.perf_counter() - tic

    def theirs():
        tic = time.perf_counter()
        states, _ = rollout.rollout(m, datas, X0, nstep=nstep)
        return time.perf_counter() - tic, states

    a, b = [], []
    for _ in range(rounds):
        a.append(ours())
        t, states = theirs()
        b.append(t)
    weight = scene.mass * 9.81
    f_ours = sum(sim.contact_forces(i, details=True)[1].normal_force.sum() for i in range(min(envs, 20))) / min(envs, 20)
    mujoco.mj_setState(m, d, states[0, -1], spec)
    mujoco.mj_forward(m, d)
    force, f_mj = np.zeros(6), 0.0
    for i in range(d.ncon):
        mujoco.mj_contactForce(m, d, i, force)
        f_mj += force[0]
    sa, sb = envs * nstep / statistics.median(a), envs * nstep / statistics.median(b)
    failed = int(np.count_nonzero(sim.failed))
    return sa, sb, f_ours / weight, f_mj / weight, sim.stats, failed


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
        sa, sb, fo, fm, stats, failed = go1_table(args.envs, max(1, args.rounds // 2))
        lines += ["", f"| Go1 standing, {args.envs} environments, 2 ms, 2 threads | env-steps/s | sum Fn / m g at 0.1 s |",
                  "|---|---|---|",
                  f"| ours (auto, rtol 1e-3) | {sa:,.0f} | {fo:.4f} |",
                  f"| MuJoCo rollout (Euler, 2 ms) | {sb:,.0f} | {fm:.4f} |",
                  f"| ours / MuJoCo (throughput) | {sa / sb:.2f}x | |",
                  "", f"ours: {stats}, failed environments {failed}"]
    text = "\n".join(lines)
    print(text)
    OUT.mkdir(exist_ok=True)
    (OUT / "stepping.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
