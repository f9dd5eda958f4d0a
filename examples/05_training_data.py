"""Generate a learning data set: random states of a robot and their inverse dynamics, saved as .npz.

    python examples/05_training_data.py [states] [out.npz]
"""

import sys
import time

import numpy as np

import dynamics

n = int(sys.argv[1]) if len(sys.argv) > 1 else 200_000
out = sys.argv[2] if len(sys.argv) > 2 else "puma560_inverse_dynamics.npz"
model = dynamics.load_urdf(dynamics.robots.path("puma560"))

rng = np.random.default_rng(0)
lo, hi = np.nan_to_num(model.lower, neginf=-np.pi), np.nan_to_num(model.upper, posinf=np.pi)
Q = rng.uniform(lo, hi, (n, model.nq))
V = rng.uniform(-2, 2, (n, model.nv))
A = rng.uniform(-5, 5, (n, model.nv))
t0 = time.perf_counter()
TAU = dynamics.inverse_dynamics(model, Q, V, A)
took = time.perf_counter() - t0
np.savez_compressed(out, q=Q, v=V, a=A, tau=TAU)
print(f"{n} states in {took:.3f} s ({took / n * 1e9:.0f} ns per state), saved to {out}")
