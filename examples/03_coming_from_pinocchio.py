"""A configuration copied from Pinocchio, mapped into our joint order (Talos branches differently, and
Pinocchio writes continuous joints as (cos, sin)).  Needs: pip install pin example-robot-data

    python examples/03_coming_from_pinocchio.py
"""

import numpy as np
import pinocchio as pin

import dynamics

path = dynamics.robots.example_robot_data("talos_data/robots/talos_reduced.urdf")
ours = dynamics.load_urdf(path, floating_base=True, strict_inertia=False)
theirs = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
names = [theirs.names[j] for j in range(1, theirs.njoints)]
print("ours:      ", ours.joint_names[:4], "...")
print("Pinocchio: ", tuple(names[:4]), "...")

rng = np.random.default_rng(0)
q_pin = pin.randomConfiguration(theirs, -np.ones(theirs.nq), np.ones(theirs.nq))
v_pin, a_pin = rng.normal(size=(2, theirs.nv))

q = dynamics.reorder(ours, q_pin, names, kind="pinocchio_q")
v, a = dynamics.reorder(ours, v_pin, names, kind="v"), dynamics.reorder(ours, a_pin, names, kind="v")
tau = dynamics.reorder(ours, dynamics.inverse_dynamics(ours, q, v, a), names, kind="v", inverse=True)
tau_pin = pin.rnea(theirs, theirs.createData(), q_pin, v_pin, a_pin)
print("largest difference from pin.rnea after reorder: %.1e N m" % np.abs(tau - tau_pin).max())
print("without reorder: %.1f N m off" % np.abs(dynamics.inverse_dynamics(ours, q_pin, v_pin, a_pin) - tau_pin).max())
