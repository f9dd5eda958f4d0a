"""A Gymnasium-style environment on dynamics.Simulator: the loop a learning or MPC code holds itself.

    python examples/06_gym_environment.py [environments] [episode steps]

`Reach` is N PUMA 560 arms stepped together, each asked to bring its hand to a goal.  Its `reset()` and
`step(action)` follow Gymnasium's vector-environment convention (observation, reward, terminated, truncated, info;
gymnasium itself is not needed).  The action is a joint torque held over one 10 ms control period; the
observation is (q, v, hand position, goal) and the reward the negative distance to the goal.  No policy is trained
here: a hand-written one (damped least squares toward the goal, a PD through the mass matrix, gravity compensation)
shows the loop.
"""

import sys
import time

import numpy as np

import dynamics


class Reach:
    """N PUMA 560 arms reaching for goals; Gymnasium's vector-environment interface."""

    def __init__(self, n=16, dt=0.01, max_steps=300, seed=0):
        self.model = dynamics.load_urdf(dynamics.robots.path("puma560"))
        self.n, self.dt, self.max_steps = n, dt, max_steps
        self.hand = "dh6"
        self.rng = np.random.default_rng(seed)
        self.q_home = np.array([0.0, -0.6, 0.3, 0.0, 0.4, 0.0])
        # adaptive steps inside each period, the integration error of each period readable after it
        self.sim = dynamics.Simulator(self.model, np.tile(self.q_home, (n, 1)), np.zeros(6), dt=dt,
                                      integrator="auto", rtol=1e-6, atol=1e-8)
        self.goal = np.zeros((n, 3))
        self.steps = np.zeros(n, int)

    def hand_position(self):
        return dynamics.frame_placement(self.model, self.sim.q, self.hand)[:, :3, 3]

    def observation(self):
        return np.concatenate([self.sim.q, self.sim.v, self.hand_position(), self.goal], axis=1)

    def reset(self, which=None):
        """Start the environments `which` (all when None) from near home, with new goals."""
        idx = np.arange(self.n) if which is None else np.flatnonzero(which)
        q = self.q_home + self.rng.uniform(-0.1, 0.1, (len(idx), 6))
        self.sim.reset(q, np.zeros(6), which=idx)
        p = dynamics.frame_placement(self.model, q, self.hand)[:, :3, 3]
        self.goal[idx] = p + self.rng.uniform(-0.15, 0.15, (len(idx), 3))
        self.steps[idx] = 0
        return self.observation(), {}

    def step(self, action):
        """Hold `action` (n, 6) joint torques over one period; Gymnasium's 5-tuple, auto-resetting what ended."""
        self.sim.step(action)
        self.steps += 1
        distance = np.linalg.norm(self.hand_position() - self.goal, axis=1)
        reward = -distance
        terminated = (distance < 0.01) | self.sim.failed
        truncated = self.steps >= self.max_steps
        info = {"distance": distance, "error_estimate": self.sim.error.copy(), "failed": self.sim.failed.copy()}
        obs = self.observation()
        done = terminated | truncated
        if done.any():
            info["final_observation"] = obs[done]
            self.reset(done)
            obs = self.observation()
        return obs, reward, terminated, truncated, info


def policy(env, obs):
    """Joint torques from a task-space goal (not learned): the joint step toward the goal by damped least squares
    on the hand's Jacobian, a PD on it through the mass matrix (about 10 rad/s on every joint, slow enough for a
    torque held 10 ms), plus gravity compensation."""
    q, v, p, goal = obs[:, :6], obs[:, 6:12], obs[:, 12:15], obs[:, 15:18]
    J = dynamics.frame_jacobian(env.model, q, env.hand)[:, :3, :]  # (n, 3, 6): the hand's linear velocity
    JJt = np.einsum("bij,bkj->bik", J, J) + 1e-3 * np.eye(3)
    dq = np.einsum("bji,bj->bi", J, np.linalg.solve(JJt, (goal - p)[..., None])[..., 0])
    M = dynamics.mass_matrix(env.model, q)
    return np.einsum("bij,bj->bi", M, 100.0 * dq - 20.0 * v) + dynamics.gravity_torques(env.model, q)


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 16
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 150
    env = Reach(n=n)
    obs, _ = env.reset()
    first = np.linalg.norm(obs[:, 12:15] - obs[:, 15:18], axis=1)
    reached, worst_error = 0, 0.0
    tic = time.perf_counter()
    for _ in range(steps):
        obs, reward, terminated, truncated, info = env.step(policy(env, obs))
        reached += int(np.count_nonzero(terminated & ~info["failed"]))
        worst_error = max(worst_error, float(np.nanmax(info["error_estimate"])))
    took = time.perf_counter() - tic
    print(f"{n} environments x {steps} steps of {env.dt * 1e3:g} ms in {took:.2f} s "
          f"({took / (n * steps) * 1e6:.0f} us per environment-step)")
    print(f"initial mean distance {first.mean():.3f} m; goals reached: {reached}")
    print(f"largest per-period error estimate: {worst_error:.2e}; failed environments: {int(env.sim.failed.sum())}")
    print(f"simulator cost: {env.sim.stats}")


if __name__ == "__main__":
    main()
