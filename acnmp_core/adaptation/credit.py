"""Credit assignment: which rewards each step of a roll-out is credited with, and the per-step
advantages of one iteration's roll-outs (REINFORCE with the mean roll-out as baseline, or
advantage-weighted regression, Peng et al. 2019)."""
from __future__ import annotations

import numpy as np

#: How a task's rewards depend on the actions (a class attribute ``credit`` of its evaluator):
#: "step" (the reward at t depends on the state at t only) or "future" (on everything before it);
#: "episode" (the whole return at every step) is set by ``noise="demos"``, not by a task.
CREDITS = ("step", "future", "episode")


def per_step_advantages(rewards: np.ndarray, kind: str = "awr", temperature: float = 0.1,
                        credit: str = "step", tolerance: float = 1e-12) -> tuple[np.ndarray, np.ndarray] | None:
    """Per-step advantages of the roll-outs of one iteration.

    rewards (1+K, T), row 0 the mean roll-out. Returns ``(rows, adv)``: the roll-outs that enter
    the policy update and their advantages (len(rows), T); None when there is nothing to learn:
    every roll-out's (credited) rewards within ``tolerance`` of the mean roll-out's at every step.

    ``credit`` says which rewards the action at step t is credited with: "step" its own reward
    only (a kinematic task, where the reward at t depends on the state at t alone), "future" its
    reward and every later one (reward-to-go: a task with dynamics, where an action also moves
    what happens after it). It is a property of the task (see :data:`CREDITS`), not a setting;
    "episode" (every step the whole return) is the exploration's: noise drawn once for the whole
    trajectory (``noise="demos"``).

    * "reinforce" (the authors'): rows 1..K, ``r_t(noisy) - r_t(mean)`` divided by its std over all
      K*T entries.
    * "awr": rows 0..K, non-negative weights ``softmax_j((r_jt - max_j r_jt) / (temperature *
      spread_t))`` times the step's relevance ``spread_t / max_t spread_t`` (spread = max - min over
      the roll-outs); the surrogate's minimiser is then the weighted mean of the roll-outs at each
      step, so repeated steps converge (advantage-weighted regression, Peng et al. 2019).
    """
    if credit == "future":
        rewards = np.cumsum(rewards[:, ::-1], axis=1)[:, ::-1]
    elif credit == "episode":
        rewards = np.repeat(rewards.sum(axis=1, keepdims=True), rewards.shape[1], axis=1)
    elif credit != "step":
        raise ValueError(f"credit: expected one of {CREDITS}, got {credit!r}")
    diff = rewards[1:] - rewards[0:1]
    if not np.any(np.abs(diff) > tolerance):
        return None
    if kind == "awr":
        spread = rewards.max(axis=0) - rewards.min(axis=0)
        z = (rewards - rewards.max(axis=0, keepdims=True)) / (temperature * np.maximum(spread, 1e-12))
        w = np.exp(z)
        w /= w.sum(axis=0, keepdims=True)
        return np.arange(len(rewards)), w * (spread / spread.max())
    s = float(diff.std())
    if not np.isfinite(s) or s < 1e-12:
        return None
    return np.arange(1, len(rewards)), diff / s
