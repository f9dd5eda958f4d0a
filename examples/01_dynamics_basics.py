"""Inverse dynamics, the mass matrix and forward dynamics of the PUMA 560, one state and a batch.

    python examples/01_dynamics_basics.py
"""

import numpy as np

import dynamics

model = dynamics.load_urdf(dynamics.robots.path("puma560"))
print(model, "joints:", model.joint_names)

q = np.array([0.0, 0.5, -1.0, 0.2, 0.3, 0.1])
v = np.array([0.1, -0.2, 0.3, 0.0, 0.5, -0.4])
a = np.array([1.0, 0.5, -0.5, 0.2, 0.0, 0.3])

tau = dynamics.inverse_dynamics(model, q, v, a)        # RNEA
M = dynamics.mass_matrix(model, q)                     # CRBA
acc = dynamics.forward_dynamics(model, q, v, tau)      # ABA, O(n)
print("tau =", np.round(tau, 4))
print("ABA(RNEA(a)) - a =", np.abs(acc - a).max())
print("M symmetric positive definite:", np.allclose(M, M.T) and np.linalg.eigvalsh(M).min() > 0)
print("gravity torques at q:", np.round(dynamics.gravity_torques(model, q), 4))

# a batch: one compiled loop spread over the cores, never a Python loop per state
rng = np.random.default_rng(0)
Q, V, A = rng.uniform(-1, 1, (3, 10_000, model.nq))
TAU = dynamics.inverse_dynamics(model, Q, V, A)
print("batch:", TAU.shape, "identity holds:", np.allclose(dynamics.forward_dynamics(model, Q, V, TAU), A))

# the elbow's coordinates by name, whatever the joint order
print("joint3 is q[%d:%d]" % (model.q_slice("joint3").start, model.q_slice("joint3").stop))
