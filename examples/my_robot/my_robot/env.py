"""ReachEnv: a 2-link planar arm (links 0.5 m and 0.4 m) whose joints move at the commanded velocity.

action (2,) joint velocities, rad/s, in [-3, 3] (``MAX_SPEED``); observation (6,): joint angles q (2,)
rad, the hand's x, y (m) and the goal's x, y (m); 50 steps of 0.02 s. The reward is minus the hand's
distance to the goal at the last step (0 before); ``info["is_success"]`` says whether the hand
ends within 3 cm of it. The goal comes from ``reset(options={"task_params": (x, y)})``.
"""
from __future__ import annotations

import gymnasium as gym
import numpy as np

LINKS = np.array([0.5, 0.4])
START = np.array([0.3, 1.2])  # joint angles (rad) every episode starts from
STEPS = 50
MAX_SPEED = 3.0  # rad/s per joint: above the demonstrations' peak (2.5), so they can be followed exactly


def hand(q: np.ndarray) -> np.ndarray:
    """The hand's (x, y) m for joint angles q (2,) rad."""
    return np.array([LINKS[0] * np.cos(q[0]) + LINKS[1] * np.cos(q[0] + q[1]),
                     LINKS[0] * np.sin(q[0]) + LINKS[1] * np.sin(q[0] + q[1])])


class ReachEnv(gym.Env):
    """See the module docstring."""

    metadata = {"render_modes": []}
    dt = 0.02

    def __init__(self):
        self.action_space = gym.spaces.Box(-MAX_SPEED, MAX_SPEED, (2,), np.float32)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (6,), np.float64)
        self.goal = np.array([0.6, 0.0])
        self.q = START.copy()
        self.t = 0

    def _obs(self) -> np.ndarray:
        return np.concatenate([self.q, hand(self.q), self.goal])

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        if options and options.get("task_params") is not None:
            self.goal = np.asarray(options["task_params"], dtype=np.float64).reshape(2)
        self.q, self.t = START.copy(), 0
        return self._obs(), {}

    def step(self, action):
        self.q = self.q + np.clip(np.asarray(action, dtype=np.float64), -MAX_SPEED, MAX_SPEED) * self.dt
        self.t += 1
        last = self.t >= STEPS
        dist = float(np.linalg.norm(hand(self.q) - self.goal))
        return self._obs(), -dist if last else 0.0, False, last, {"is_success": dist < 0.03, "distance": dist}
