"""Simulate the planar 2R arm under PD control, read the report, and save a plot.

    python examples/02_simulate_and_plot.py [out.png]
"""

import sys

import numpy as np

import dynamics
from dynamics.torques import PD

arm = dynamics.load_urdf(dynamics.robots.path("planar_2r"))
target = np.array([0.8, -0.4])
gravity_hold = dynamics.gravity_torques(arm, target)           # feed-forward: hold the target against gravity
traj = dynamics.simulate(arm, [0.0, 0.0], [0.0, 0.0], 3.0, torque=PD(target, 2000.0, 200.0, tau_ff=gravity_hold),
                         sample_dt=0.01)

r = traj.report
print(f"status {r['status']}, {r['steps']} steps in {r['wall_time_s'] * 1e3:.1f} ms, "
      f"error estimate {r['error_estimate']:.1e}, energy drift {r['energy_drift']:.1e}")
print("final q:", np.round(traj.q[-1], 6), "target:", target)

out = sys.argv[1] if len(sys.argv) > 1 else "trajectory.png"
dynamics.plot.trajectory(traj, out, joint_names=arm.joint_names)
print("plot saved to", out)
