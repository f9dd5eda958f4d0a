"""The HTTP service from Python: upload a URDF, compute a batch, kinematics, simulate.  Start the service first
(`python -m service`), or point DYNAMICS_URL at one.

    python examples/04_client.py
"""

import os

import numpy as np

import dynamics
from service.client import Client

url = os.environ.get("DYNAMICS_URL", "http://127.0.0.1:8000")
with Client(url, timeout=120) as client:
    arm = client.upload(dynamics.robots.path("rp_arm"), name="my-rp-arm")
    print("uploaded", arm.id, "nq =", arm.nq)
    rng = np.random.default_rng(0)
    q, v, a = rng.uniform(-1, 1, (3, 1000, arm.nq))
    tau = arm.inverse_dynamics(q, v, a)                          # travels as .npz both ways
    local = dynamics.inverse_dynamics(dynamics.load_urdf(dynamics.robots.path("rp_arm")), q, v, a)
    print("batch of", tau.shape[0], "- largest difference from the library:", np.abs(tau - local).max())
    T = arm.frame_placement(q[0], "link2")                       # the library's names and shapes: (4, 4)
    J = arm.frame_jacobian(q[0], "link2", reference="world")     # (6, nv)
    q_ik, report = arm.inverse_kinematics("link2", T[:3, 3], q[0] + 0.2, position_only=True)
    print("frames:", arm.frame_names, "- IK back to link2's position:", report["status"],
          f"(|e| = {report['residual']:.1e} m)")
    traj = arm.simulate(q[0], np.zeros(arm.nv), 1.0, sample_dt=0.01,
                        torque=dynamics.torques.PD(np.zeros(arm.nq), 50.0, 5.0))  # or {"type": "pd", ...}
    print("simulated", traj.q.shape, "status", traj.report["status"])
