"""E2's push as a step-based Gymnasium environment, for the peers that learn a policy step by step.

The same PyBullet world as :class:`~acnmp_core.tasks.push.task.PlanarPushTask` (one
:class:`~acnmp_core.sim.planar_arm.PlanarArmSim`), driven one control step at a time: an action
(N,) in [-1, 1] moves the joint targets by ``action * MAX_STEP`` rad (the position controller
tracks them, as it tracks a trajectory's rows), and an episode lasts
:data:`~acnmp_core.tasks.push.demos.N_STEPS` steps from the demonstrations' start posture.

Observation (3N + 5,): joint angles (N,) rad, joint targets (N,) rad, their difference (N,), the
cylinder's (x, y) m, the target's (x, y) m and the phase in [0, 1]. Reward per step: minus the
cylinder's distance (m) to the target divided by the episode's steps (ACNMP's "distance" reward
of E2). ``info["success_ever"]`` and ``info["min_error"]`` carry the task's verdict so far: the
cylinder within the tolerance of the target, and its distance (m), at the current step (at the
last step: E2's success and error).

:func:`demo_transitions` replays demonstrations as (observation, action) pairs for behaviour
cloning: each row-to-row change of the joint targets as an action.
"""
from __future__ import annotations

import functools

import numpy as np

from ...validation import check_array
from .demos import N_STEPS

#: largest change (rad) of a joint target in one control step (an action of 1); the demonstrations'
#: largest is about a third of it
MAX_STEP = 0.05


@functools.lru_cache(maxsize=1)
def _env_class():
    """The environment class, built on first use (gymnasium is imported only then)."""
    import gymnasium as gym
    from gymnasium import spaces

    class PlanarPushEnv(gym.Env):
        """E2's push, one control step per ``step`` (module docstring).

        Parameters: q0 (N,) rad the start posture; target (2,) m; tolerance m; ``sim_kwargs`` for
        :class:`~acnmp_core.sim.planar_arm.PlanarArmSim` (e.g. the cylinder's start).
        """

        metadata = {"render_modes": []}
        #: steps per episode (the environment truncates itself there)
        max_episode_steps = N_STEPS

        def __init__(self, q0, target, tolerance: float = 0.03, **sim_kwargs):
            from ...sim.planar_arm import PlanarArmSim

            self.sim = PlanarArmSim(**sim_kwargs)
            self.q0 = check_array("q0", q0, shape=(self.sim.n_joints,))
            self.target = check_array("target", target, shape=(2,))
            self.tolerance = float(tolerance)
            n = self.sim.n_joints
            self.action_space = spaces.Box(-1.0, 1.0, (n,), dtype=np.float32)
            self.observation_space = spaces.Box(-np.inf, np.inf, (3 * n + 5,), dtype=np.float64)
            self._k, self._cmd, self._q, self._obj = 0, self.q0.copy(), self.q0.copy(), np.zeros(2)

        def _obs(self) -> np.ndarray:
            return np.r_[self._q, self._cmd, self._cmd - self._q, self._obj, self.target, self._k / N_STEPS]

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            self._obj = np.asarray(self.sim.reset(self.q0), dtype=np.float64)
            self._k, self._cmd, self._q = 0, self.q0.copy(), self.q0.copy()
            return self._obs(), {}

        def step(self, action):
            a = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
            prev = self._cmd
            self._cmd = np.clip(prev + MAX_STEP * a, self.sim.limits[:, 0], self.sim.limits[:, 1])
            q, obj = self.sim.control_step(self._cmd, (self._cmd - prev) / self.sim.control_dt)
            self._q, self._obj, self._k = np.asarray(q), np.asarray(obj), self._k + 1
            dist = float(np.linalg.norm(self._obj - self.target))
            info = {"success_ever": dist <= self.tolerance, "min_error": dist}
            return self._obs(), -dist / N_STEPS, False, self._k >= N_STEPS, info

        def close(self):
            self.sim.close()

    return PlanarPushEnv


def push_env(q0: np.ndarray, target: np.ndarray, tolerance: float = 0.03, **sim_kwargs):
    """A new step-based E2 environment (module docstring) from posture ``q0`` (N,) rad to push the
    cylinder to ``target`` (2,) m."""
    return _env_class()(q0, target, tolerance, **sim_kwargs)


def demo_transitions(trajectories: np.ndarray, targets: np.ndarray, **sim_kwargs) -> tuple[np.ndarray, np.ndarray]:
    """Demonstrations (M, T, N) rad with their targets (M, 2) m replayed in the environment:
    (observations (M*(T-1), 3N+5), actions (M*(T-1), N)), each action the change of the joint
    targets from one row to the next over :data:`MAX_STEP` (clipped to [-1, 1])."""
    trajectories = check_array("trajectories", trajectories, ndim=3)
    observations, actions = [], []
    for traj, target in zip(trajectories, check_array("targets", targets, shape=(len(trajectories), 2))):
        env = push_env(traj[0], target, **sim_kwargs)
        try:
            obs, _ = env.reset()
            for row in np.clip(np.diff(traj, axis=0) / MAX_STEP, -1.0, 1.0):
                observations.append(obs)
                actions.append(row)
                obs, *_ = env.step(row)
        finally:
            env.close()
    return np.array(observations), np.array(actions)
