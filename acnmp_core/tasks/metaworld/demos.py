"""Demonstrations of the Meta-World tasks by Meta-World's own scripted policies.

:func:`expert_episode` runs ``metaworld.policies.Sawyer<Task>V3Policy`` for :data:`~.scene.N_STEPS`
steps at one position and records, per step k, the hand's position after it (m) and the gripper
command the policy sent: the trajectory (T, 4) the adapter tracks
(:mod:`~acnmp_core.tasks.metaworld.scene`). :func:`metaworld_demos` draws positions from a task's
training region and keeps the episodes that succeeded (Meta-World's success at any step); the
failed ones are not used. :func:`expert_transitions` gives the same episodes as (observation,
action) pairs, for a peer that learns a step-based policy by behaviour cloning.
"""
from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np

from .scene import N_STEPS, make_env, set_task, task

#: the scripted policy of each task (class names in metaworld.policies)
EXPERTS = {"reach-v3": "SawyerReachV3Policy", "push-v3": "SawyerPushV3Policy",
           "pick-place-v3": "SawyerPickPlaceV3Policy", "window-open-v3": "SawyerWindowOpenV3Policy",
           "button-press-v3": "SawyerButtonPressV3Policy"}
#: demonstrations drawn per task (those that fail are dropped) and the seed of their positions
N_DEMOS = 12
DEMO_SEED = 1000


@dataclass(frozen=True)
class ExpertEpisode:
    """One episode of the scripted expert.

    params : (P,) the task parameters (m). trajectory : (T, 4) hand x, y, z (m) after each step and
    the gripper command. observations : (T, 39) what the policy saw before each step. actions : (T, 4)
    what it sent. success : Meta-World's success at some step. first_success : that step (1-based),
    or None.
    """

    params: np.ndarray
    trajectory: np.ndarray
    observations: np.ndarray
    actions: np.ndarray
    success: bool
    first_success: int | None


def expert_episode(kind: str, params: np.ndarray, steps: int = N_STEPS) -> ExpertEpisode:
    """Meta-World's scripted policy for ``kind`` run ``steps`` steps at ``params`` (P,)."""
    from metaworld import policies

    env = make_env(kind)
    try:
        env.reset(seed=0)
        obs = set_task(kind)(env, params)
        policy = getattr(policies, EXPERTS[task(kind).env_name])()
        # Meta-World's policies warn at every step that their gains exceed the clipped range
        warnings.filterwarnings("ignore", "Constant", UserWarning, "metaworld")
        rows, observations, actions, first = [], [], [], None
        for k in range(steps):
            action = np.asarray(policy.get_action(obs), dtype=np.float64)
            observations.append(obs)
            actions.append(action)
            obs, _reward, _term, _trunc, info = env.step(action)
            obs = np.asarray(obs, dtype=np.float64)
            rows.append(np.r_[obs[:3], np.clip(action[3], -1.0, 1.0)])
            if first is None and info["success_ever"]:
                first = k + 1
    finally:
        env.close()
    return ExpertEpisode(np.asarray(params, dtype=np.float64), np.array(rows), np.array(observations),
                         np.clip(np.array(actions), -1.0, 1.0), first is not None, first)


def expert_succeeds(kind: str, params: np.ndarray) -> bool:
    """Whether Meta-World's scripted policy succeeds at ``params`` within an episode."""
    return expert_episode(kind, params).success


@functools.lru_cache(maxsize=8)
def expert_episodes(kind: str, n: int = N_DEMOS, seed: int = DEMO_SEED) -> tuple[ExpertEpisode, ...]:
    """The successful ones of ``n`` expert episodes at positions drawn from ``kind``'s training
    region with generator ``seed`` (cached: about 0.1 s each)."""
    spec = task(kind)
    rng = np.random.default_rng(seed)
    episodes = [expert_episode(kind, spec.sample_training(rng)) for _ in range(n)]
    return tuple(ep for ep in episodes if ep.success)


def metaworld_demos(kind: str, n: int = N_DEMOS, seed: int = DEMO_SEED):
    """The demonstrations of ``kind`` as :class:`~acnmp_core.data.demo_io.DemoArrays`: times the phase
    (T,) in [0, 1], values (N, T, 4) (hand x, y, z m; gripper command), task parameters (N, P) m."""
    from ...data.demo_io import DemoArrays

    episodes = expert_episodes(kind, n, seed)
    spec = task(kind)
    times = np.tile(np.linspace(0.0, 1.0, N_STEPS), (len(episodes), 1))
    return DemoArrays(times, np.stack([ep.trajectory for ep in episodes]), np.stack([ep.params for ep in episodes]),
                      task_param_names=np.array(spec.param_names),
                      value_names=np.array(["hand_x", "hand_y", "hand_z", "gripper"]))


def expert_transitions(kind: str, n: int = N_DEMOS, seed: int = DEMO_SEED) -> tuple[np.ndarray, np.ndarray]:
    """The demonstrations' (observation (M, 39), action (M, 4)) pairs, M = N x T."""
    episodes = expert_episodes(kind, n, seed)
    return (np.concatenate([ep.observations for ep in episodes]), np.concatenate([ep.actions for ep in episodes]))
