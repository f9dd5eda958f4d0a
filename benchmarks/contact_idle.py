"""What contact costs a robot that touches nothing (issue 19: <= 10 %), and the cold start of a first contact
simulation.

    python -m benchmarks.contact_idle [--rounds N] [--cold]

Go1 (example-robot-data) under PD, one sphere per foot, the ground 10 m below (the contact code skipped: dynamics.contact.clearance): the
run's wall time (``report["wall_time_s"]``) with and without ``contact``, alternately in one process, rk4
(dt = 1 ms, the same steps both ways) and auto (with the default 1,001 samples, and with 2: what a sample
costs); the ratio of the medians.  ``--cold``: the CPU seconds of a
fresh interpreter with an empty numba cache (and none in the tree's __pycache__) running the first simulate of
the ball drop with contact, and the same ball without contact, one after the other.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

FEET = ["FR_foot", "FL_foot", "RR_foot", "RL_foot"]


def go1():
    import dynamics
    model = dynamics.load_urdf(dynamics.robots.example_robot_data("go1_description/urdf/go1.urdf"),
                               floating_base=True, strict_inertia=False)
    q = model.neutral().copy()
    for leg in ("FR", "FL", "RR", "RL"):
        for joint, angle in (("hip", 0.0), ("thigh", 0.9), ("calf", -1.8)):
            q[model.q_index[model.joint_names.index(f"{leg}_{joint}_joint")]] = angle
    kp = np.r_[np.zeros(6), np.full(12, 50.0)]
    kd = np.r_[np.zeros(6), np.full(12, 1.0)]
    return model, q, dynamics.torques.PD(q.copy(), kp, kd)


def idle(rounds):
    import warnings
    import dynamics
    model, q0, pd = go1()
    contact = dynamics.Contact(ground=dynamics.Ground(height=-10.0),
                               geometries=[dynamics.Sphere(f, 0.02) for f in FEET])
    out = {}
    for integrator, kw in (("rk4", dict(integrator="rk4", dt=1e-3)), ("auto", {}),
                           ("auto, 2 samples", dict(sample_dt=0.5))):
        walls = {"none": [], "contact": []}
        for r in range(rounds + 1):
            for name, c in (("none", None), ("contact", contact)):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    tr = dynamics.simulate(model, q0, np.zeros(model.nv), 0.5, torque=pd, contact=c,
                                           error_estimate="none", **kw)
                if r:  # round 0 compiles
                    walls[name].append(tr.report["wall_time_s"])
        med = {k: statistics.median(v) for k, v in walls.items()}
        out[integrator] = {"without_s": med["none"], "with_s": med["contact"], "ratio": med["contact"] / med["none"],
                           "steps": tr.report["steps"]}
    return out


COLD = r"""
import time, resource, numpy as np, dynamics
BALL = '''<robot name="ball"><link name="ball"><inertial><mass value="0.2"/>
<inertia ixx="2e-4" iyy="2e-4" izz="2e-4" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>'''
ball = dynamics.load_urdf(BALL, floating_base=True)
q0 = np.array([0, 0, 0.3, 0, 0, 0, 1.0])
cpu = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_utime + resource.getrusage(resource.RUSAGE_SELF).ru_stime
c0, w0 = cpu(), time.time()
dynamics.simulate(ball, q0, np.zeros(6), 0.3, contact=dynamics.Contact(geometries=[dynamics.Sphere("ball", 0.05)]))
c1, w1 = cpu(), time.time()
dynamics.simulate(ball, q0, np.zeros(6), 0.3)
c2, w2 = cpu(), time.time()
print({"first_contact_cpu_s": c1 - c0, "first_contact_wall_s": w1 - w0, "then_no_contact_cpu_s": c2 - c1})
"""


def cold():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    for dirpath, _, files in os.walk(os.path.join(root, "dynamics")):
        for f in files:
            if f.endswith((".nbi", ".nbc")):
                os.remove(os.path.join(dirpath, f))
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache, "PYTHONPATH": root}
        t0 = time.time()
        proc = subprocess.run([sys.executable, "-c", COLD], capture_output=True, text=True, env=env, cwd=root)
        print(proc.stderr[-2000:], file=sys.stderr)
        return {**eval(proc.stdout.strip().splitlines()[-1]), "process_wall_s": time.time() - t0}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--cold", action="store_true")
    args = ap.parse_args()
    out = {"idle": idle(args.rounds)}
    if args.cold:
        out["cold"] = cold()
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
