"""Step-based deep RL peers: stable-baselines3's PPO and SAC on a task's step-based environment at one position.

Each runs at its documented defaults (``PPO("MlpPolicy", env)``, ``SAC("MlpPolicy", env)``,
stable-baselines3 2.9) on the task's step-based environment (the peers comparison's
:meth:`~acnmp_core.experiments.peers.tasks.PeerTask.step_env`: Meta-World's own environment, Gymnasium's
``Pusher-v5``, E2's push stepped in PyBullet), every episode at the test position, its reward per step.

The metric is every method's: episodes executed until the method's deterministic output first
succeeds. The policy's deterministic action (``predict(deterministic=True)``) runs one evaluation
episode before training and then after every ``eval_every`` training episodes; evaluation episodes
count. An episode's success and error are what its environment reports at its last step
(``info["success_ever"]``, ``info["min_error"]``). The run stops at the first evaluation that
succeeds or once ``budget`` episodes ran.

``warm_start="bc"``: before RL the policy's mean action is fitted to the demonstrations'
(observation, action) pairs by behaviour cloning (mean squared error, Adam, ``bc_steps`` batches of
``bc_batch``), the pretraining recipe of the stable-baselines3 documentation; the RL then starts
from that policy with every other setting at its default.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from . import require

ALGORITHMS = ("ppo", "sac")


@dataclass(frozen=True)
class StepBasedConfig:
    """algorithm : "ppo" or "sac". budget : episodes at most (evaluations included). eval_every :
    training episodes between two evaluations. warm_start : None or "bc". bc_steps, bc_batch, bc_lr :
    the behaviour cloning's batches, batch size and Adam rate."""

    algorithm: str
    budget: int
    eval_every: int = 10
    warm_start: str | None = None
    bc_steps: int = 3000
    bc_batch: int = 64
    bc_lr: float = 1e-3

    def __post_init__(self):
        if self.algorithm not in ALGORITHMS:
            raise ValueError(f"algorithm: expected one of {ALGORITHMS}, got {self.algorithm!r}")
        if self.warm_start not in (None, "bc"):
            raise ValueError(f"warm_start: expected None or 'bc', got {self.warm_start!r}")


@dataclass(frozen=True)
class StepBasedResult:
    """episodes : executed (training and evaluation). success : an evaluation succeeded within the
    budget. curve : (episodes so far, evaluation's error) per evaluation. train_episodes,
    eval_episodes : the two kinds counted apart. bc_loss : the cloning's last loss, or None."""

    episodes: int
    success: bool
    curve: list
    train_episodes: int
    eval_episodes: int
    bc_loss: float | None


def _episode_steps(env) -> int:
    """The environment's episode length (its TimeLimit), for the training's step count."""
    steps = getattr(env.spec, "max_episode_steps", None) if getattr(env, "spec", None) else None
    return int(steps or getattr(env.unwrapped, "max_episode_steps", 0) or 1000)


def behaviour_clone(model, observations: np.ndarray, actions: np.ndarray, config: StepBasedConfig, seed: int) -> float:
    """Fit ``model``'s deterministic action to ``actions`` (M, 4) at ``observations`` (M, 39); the last loss."""
    import torch

    policy = model.policy
    obs = torch.as_tensor(observations, dtype=torch.float32)
    act = torch.as_tensor(actions, dtype=torch.float32)
    gen = torch.Generator().manual_seed(int(seed))
    optimiser = torch.optim.Adam(policy.parameters(), lr=config.bc_lr)
    policy.set_training_mode(True)
    loss = torch.tensor(0.0)
    for _ in range(config.bc_steps):
        idx = torch.randint(0, len(obs), (config.bc_batch,), generator=gen)
        if config.algorithm == "ppo":
            mean = policy.get_distribution(obs[idx]).distribution.mean
        else:
            mean = policy.actor(obs[idx], deterministic=True)
        loss = torch.mean((mean - act[idx]) ** 2)
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
    policy.set_training_mode(False)
    return float(loss.detach())


def run_step_based(make_env: Callable[[], Any], config: StepBasedConfig, seed: int,
                   demonstrations: tuple[np.ndarray, np.ndarray] | None = None) -> StepBasedResult:
    """Train ``config.algorithm`` on environments from ``make_env`` (each episode at the test
    position, time-limited, reporting ``success_ever`` and ``min_error``; module docstring) until its
    deterministic policy succeeds or the budget is spent. ``demonstrations`` (observations,
    actions): needed by ``warm_start="bc"``."""
    import torch

    sb3 = require("stable_baselines3", f"stable-baselines3 {config.algorithm.upper()}")
    PPO, SAC = sb3.PPO, sb3.SAC
    BaseCallback = require("stable_baselines3.common.callbacks", "stable-baselines3").BaseCallback

    torch.manual_seed(int(seed))
    env, eval_env = make_env(), make_env()
    model = (PPO if config.algorithm == "ppo" else SAC)("MlpPolicy", env, seed=int(seed), verbose=0, device="cpu")
    bc_loss = None
    if config.warm_start == "bc":
        if demonstrations is None:
            raise ValueError("warm_start='bc' needs the demonstrations' (observations, actions)")
        bc_loss = behaviour_clone(model, *demonstrations, config, seed)
    counts = {"train": 0, "eval": 0}
    curve: list = []
    state = {"success": False}

    def evaluate() -> bool:
        obs, _ = eval_env.reset(seed=int(seed))
        info: dict = {}
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _r, terminated, truncated, info = eval_env.step(action)
            done = terminated or truncated
        counts["eval"] += 1
        curve.append([counts["train"] + counts["eval"], float(info.get("min_error", np.nan))])
        return bool(info.get("success_ever", False))

    def spent() -> bool:
        return counts["train"] + counts["eval"] >= config.budget

    class Episodes(BaseCallback):
        def _on_step(self) -> bool:
            for done in self.locals["dones"]:
                if not done:
                    continue
                counts["train"] += 1
                if spent():
                    return False
                if counts["train"] % config.eval_every == 0:
                    if evaluate():
                        state["success"] = True
                        return False
                    if spent():
                        return False
            return True

    if evaluate():
        state["success"] = True
    elif not spent():
        # more steps than the budget's episodes can take: the callback stops at the budget
        model.learn(total_timesteps=config.budget * _episode_steps(env), callback=Episodes())
    env.close()
    eval_env.close()
    return StepBasedResult(counts["train"] + counts["eval"], state["success"], curve, counts["train"],
                           counts["eval"], bc_loss)
