"""Step-based deep RL peers: stable-baselines3's PPO and SAC on a Meta-World task at one position.

Each runs at its documented defaults (``PPO("MlpPolicy", env)``, ``SAC("MlpPolicy", env)``,
stable-baselines3 2.9) on the environment the trajectory methods execute in
(:func:`~acnmp_core.tasks.metaworld.scene.make_env`): the task's observation (39) and actions
(4), Meta-World's dense reward per step, episodes of :data:`~acnmp_core.tasks.metaworld.scene.N_STEPS`
steps at the test position.

The metric is every method's: episodes executed until the method's deterministic output first
succeeds. The policy's deterministic action (``predict(deterministic=True)``) runs one evaluation
episode before training and then after every ``eval_every`` training episodes; evaluation episodes
count. The run stops at the first evaluation that succeeds or once ``budget`` episodes ran.

``warm_start="bc"``: before RL the policy's mean action is fitted to the demonstrations'
(observation, action) pairs by behaviour cloning (mean squared error, Adam, ``bc_steps`` batches of
``bc_batch``), the pretraining recipe of the stable-baselines3 documentation; the RL then starts
from that policy with every other setting at its default.
"""
from __future__ import annotations

from dataclasses import dataclass

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


def _fixed_task_env(kind: str, params: np.ndarray):
    """The task's environment reset at ``params`` every episode, cut at N_STEPS steps."""
    import gymnasium as gym

    from ..tasks.metaworld.scene import N_STEPS, make_env, set_task

    setter = set_task(kind)

    class FixedTask(gym.Wrapper):
        def reset(self, *, seed=None, options=None):
            self.env.reset(seed=seed)
            return setter(self.env, params), {}

    return gym.wrappers.TimeLimit(FixedTask(make_env(kind)), N_STEPS)


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


def run_step_based(kind: str, params: np.ndarray, config: StepBasedConfig, seed: int,
                   demonstrations: tuple[np.ndarray, np.ndarray] | None = None) -> StepBasedResult:
    """Train ``config.algorithm`` at ``params`` (P,) until its deterministic policy succeeds or the
    budget is spent. ``demonstrations`` (observations, actions): needed by ``warm_start="bc"``."""
    import torch

    sb3 = require("stable_baselines3", f"stable-baselines3 {config.algorithm.upper()}")
    PPO, SAC = sb3.PPO, sb3.SAC
    BaseCallback = require("stable_baselines3.common.callbacks", "stable-baselines3").BaseCallback

    from ..tasks.metaworld.scene import N_STEPS

    torch.manual_seed(int(seed))
    env, eval_env = _fixed_task_env(kind, params), _fixed_task_env(kind, params)
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
        for _ in range(N_STEPS):
            action, _ = model.predict(obs, deterministic=True)
            obs, _r, terminated, truncated, info = eval_env.step(action)
            if terminated or truncated:
                break
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
        model.learn(total_timesteps=config.budget * N_STEPS, callback=Episodes())
    env.close()
    eval_env.close()
    return StepBasedResult(counts["train"] + counts["eval"], state["success"], curve, counts["train"],
                           counts["eval"], bc_loss)
