"""What contact costs a robot that touches nothing (issue 19: <= 10 %).

    python -m benchmarks.contact_idle [--rounds N]

Go1 (example-robot-data) under PD, one sphere per foot, the ground 10 m below (the broad phase finds nothing to
touch): the run's wall time (``report["wall_time_s"]``) with and without ``contact``, alternately in one process,
rk4 (dt = 1 ms, the same steps both ways) and auto (with the default 1,001 samples, and with 2: what a sample
costs); the ratio of the medians.  Printed as a markdown table and written to benchmarks/out/contact_idle.md.
"""

import argparse
import statistics
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "out" / "contact_idle.md"

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
                if r:  # round 0 warms up (first calls, caches)
                    walls[name].append(tr.report["wall_time_s"])
        med = {k: statistics.median(v) for k, v in walls.items()}
        out[integrator] = {"without_s": med["none"], "with_s": med["contact"], "ratio": med["contact"] / med["none"],
                           "steps": tr.report["steps"]}
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    out = idle(args.rounds)
    lines = [f"Go1 under PD, four foot spheres, the ground 10 m below; 0.5 s, median of {args.rounds} rounds "
             "(alternated).", "",
             "| run | steps | without contact (ms) | with contact (ms) | ratio | target |", "|---|---:|---:|---:|---:|---|"]
    for name, r in out.items():
        lines.append(f"| {name} | {r['steps']} | {r['without_s'] * 1e3:.2f} | {r['with_s'] * 1e3:.2f} | "
                     f"{r['ratio']:.3f} | <= 1.10: {'met' if r['ratio'] <= 1.10 else 'MISSED'} |")
    text = "\n".join(lines)
    print(text)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(text + "\n")


if __name__ == "__main__":
    main()
