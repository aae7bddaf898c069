"""``Pusher-v5`` at a fixed task as a step-based environment, for the peers that learn a policy step by step.

Gymnasium's own environment with its own observation (23) and torque actions (7), its own reward
per step and 100 steps per episode; after every ``reset`` the object and the goal are placed at the
task parameters (:func:`~acnmp_core.tasks.pusher.scene.set_pusher_task`). ``info["success_ever"]``
and ``info["min_error"]`` carry the task's verdict so far: the object within
:data:`~acnmp_core.tasks.pusher.scene.PUSHER_SUCCESS_M` of the goal, and its distance (m), at the
current step (at the last step: the task's success and error, as the ``pusher`` robot reports them).

:func:`demo_transitions` replays the demonstrations' joint targets with the ``pusher`` robot's PD
controller and records what it saw and the torques it sent, for behaviour cloning.
"""
from __future__ import annotations

import functools

import numpy as np

from .scene import ENV_ID, N_STEPS, PUSHER_KD, PUSHER_KP, PUSHER_SUCCESS_M, set_pusher_task


@functools.lru_cache(maxsize=1)
def _wrapper():
    """The wrapper class, built on first use (gymnasium is imported only then)."""
    import gymnasium as gym

    class PusherAt(gym.Wrapper):
        """Pusher-v5 reset to one task (module docstring)."""

        def __init__(self, env, params):
            super().__init__(env)
            self.params = np.asarray(params, dtype=np.float64).reshape(4)

        def reset(self, *, seed=None, options=None):
            _obs, info = self.env.reset(seed=seed, options=options)
            return set_pusher_task(self.env, self.params), info

        def step(self, action):
            obs, reward, terminated, truncated, info = self.env.step(action)
            dist = float(np.linalg.norm(obs[17:19] - obs[20:22]))
            return obs, reward, terminated, truncated, {**info, "success_ever": dist <= PUSHER_SUCCESS_M,
                                                         "min_error": dist}

    return PusherAt


def pusher_env(params: np.ndarray):
    """A new ``Pusher-v5`` whose every episode has the object and the goal at ``params`` (4,) m."""
    import gymnasium as gym

    return _wrapper()(gym.make(ENV_ID, max_episode_steps=N_STEPS), params)


def demo_transitions(trajectories: np.ndarray, params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint-target trajectories (M, T, 7) rad at their task parameters (M, 4) m, tracked by the
    ``pusher`` robot's PD controller (``KP (q* - q) - KD qdot``, clipped to the torque limits):
    (observations (M*T, 23), torques (M*T, 7)), one pair per step."""
    observations, actions = [], []
    for traj, p in zip(np.asarray(trajectories, dtype=np.float64), np.asarray(params, dtype=np.float64)):
        env = pusher_env(p)
        try:
            obs, _ = env.reset(seed=0)
            low, high = env.action_space.low, env.action_space.high
            for target in traj:
                action = np.clip(PUSHER_KP * (target - obs[:7]) - PUSHER_KD * obs[7:14], low, high)
                observations.append(obs)
                actions.append(action)
                obs, *_ = env.step(action.astype(env.action_space.dtype))
        finally:
            env.close()
    return np.array(observations), np.array(actions)
