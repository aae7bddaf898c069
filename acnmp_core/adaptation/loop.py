"""Adaptation of a CNMP to a new condition by policy gradient with simultaneous supervised learning.

This is the "A" of ACNMP (Akbulut et al., CoRL 2020, Sec. 3.2). The network's mean trajectory for
one conditioning query is the mean of a Gaussian policy over trajectories with a hand-set
exploration std. Each iteration executes the mean and ``noisy_per_iter`` noisy trajectories
(time-correlated noise, :class:`~acnmp_core.adaptation.exploration.SmoothNoise`) through a
:class:`~acnmp_core.rollout.RolloutEvaluator`, then updates the network:

* **Credit**: each step's action is credited with the reward difference to the mean roll-out at
  that step only (the authors'), or, for a task whose rewards depend on what happened before
  (dynamics, contacts: its evaluator's ``credit = "future"``), with the rewards from that step on.
* **Policy update**, two modes (``advantage``):

  - "awr" (default): at every step the target is the roll-outs' average weighted by
    ``softmax((r - max r) / (temperature * spread))`` (the mean roll-out included); the mean is
    regressed onto it, step by step weighted by how much the reward there differs between the
    roll-outs, until it is within ``fit_tolerance`` stds or ``max_reuse`` steps (advantage-weighted
    regression, Peng et al. 2019; its minimiser is the weighted average, so repeated steps
    converge instead of running away).
  - "reinforce" (the authors' update): ``A_t = r_t(noisy) - r_t(mean)`` divided by its std over the
    iteration; loss ``mean_t sum_d w_td A_t (a_td - mu_td)^2 / (2 sigma_d^2)`` (REINFORCE with a
    fixed std); the roll-out is reused with ``w = min(1, p_new / p_old)`` per step and dimension
    until the mean has moved more than ``reuse_threshold`` stds or ``max_reuse`` times.

* **Simultaneous SL**: ``sl_steps`` supervised NLL steps on the demonstrations before the first
  policy step and ``sl_steps_reuse`` before each further one (mode "acnmp"), so the skill keeps the
  demonstrations' shape. SL and RL keep separate Adam moments (their gradients differ in scale by
  orders of magnitude) and the SL rate is lower: an SL step moves the extrapolated output at
  random, by an amount set by the rate alone.
* **Exploration** (unit-free): the std starts at ``explore_scale`` times the demonstrations' std of
  each output and follows the remaining error, ``std = std0 * clip(err / err0, explore_min, 1)``,
  ``err`` the mean roll-out's error (``RolloutBatch.errors``, else minus its return) and ``err0``
  the first one: the authors tie the std to the remaining error in every experiment, each with
  its own constants; a ratio needs none. ``explore_error_gain`` and ``explore_cap`` give the
  authors' absolute form instead, ``min(gain * err, cap)`` in raw units (their E4: 3 x error, at most
  0.08 rad); off by default. ``noise="cubic"`` draws the noise as the authors' E4 does (a few
  samples smoothed into one cubic polynomial per output, :class:`~acnmp_core.adaptation.exploration.CubicNoise`;
  off by default). An iteration whose roll-outs all returned the same rewards (no
  advantage, nothing to learn) takes no policy step; ``signal_tolerance`` says when rewards count
  as the same: a simulator's contact solver jitters an
  untouched object by micrometres, so rewards that should be equal differ by far less than any real
  effect (E4: about 1e-6 against 1e-2 once the paddle touches the cube).

Ablations: ``mode="rl_only"`` turns the supervised steps off; ``mode="lfd_only"`` executes the
conditioned mean once and does not adapt. docs/experiments/adaptation.md says how the defaults
were chosen.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np
import torch

from ..data.demos import DemoSet
from ..model.cnmp import CNMP, Query
from ..model.optim_step import Stepper, adam
from ..model.training import TrainConfig, make_sampler, nll_loss
from ..rollout import RolloutBatch, RolloutEvaluator
from ..threads import with_training_threads
from .config import AdaptConfig, AdaptResult, AdaptTarget, IterationLog
from .credit import per_step_advantages
from .exploration import CubicNoise, DemoNoise, SmoothNoise, explore_std


@dataclass
class _Rollout:
    """A noisy roll-out kept for reuse (normalised units): executed trajectory tau (T, D),
    per-step advantage (T,), exploration std (D,), the mean that generated it (T, D)."""

    tau: torch.Tensor
    adv: torch.Tensor
    std: torch.Tensor
    mu_old: torch.Tensor


class _Updater:
    """The network updates of one adaptation: RL steps on roll-outs and SL steps on the demos."""

    def __init__(self, model: CNMP, query: Query, cfg: AdaptConfig, demos: DemoSet, train_cfg: TrainConfig,
                 gen: torch.Generator, params: list[torch.nn.Parameter] | None = None) -> None:
        self.model, self.query, self.cfg, self.gen = model, query, cfg, gen
        self.sampler = make_sampler(model, demos, train_cfg) if cfg.mode == "acnmp" else None
        params = list(model.parameters()) if params is None else params
        # Separate Adam moments for the RL and the SL steps: their gradients differ in scale by
        # orders of magnitude, and a shared second moment lets the larger one silence the other.
        self.opt_rl = Stepper(adam(params, lr=cfg.lr))
        self.opt_sl = Stepper(adam(params, lr=cfg.sl_lr))

    def mean(self) -> torch.Tensor:
        """Current mean (T, D), normalised units, no gradient."""
        with torch.no_grad():
            return self.model.mean_normalized(self.query)

    def sl(self, steps: int) -> None:
        """``steps`` supervised steps (plain Gaussian NLL) on the demonstrations."""
        if self.sampler is None:
            return
        for _ in range(steps):
            loss = nll_loss(self.model, self.sampler.sample(self.cfg.sl_batch_size, self.gen), 0.0)
            self.opt_sl.zero_grad()
            loss.backward()
            self.opt_sl.step()

    def rl(self, rollouts: list[_Rollout], reuse: bool) -> None:
        """One policy step on ``rollouts``: ``mean_t sum_d A_t (a_td - mu_td)^2 / (2 sigma_d^2)``,
        with importance weights min(1, p_new/p_old) per step and dimension when ``reuse``."""
        mu = self.model.mean_normalized(self.query)  # (T, D)
        loss = 0.0
        for r in rollouts:
            sq = (r.tau - mu) ** 2 / (2 * r.std**2)  # (T, D)
            if reuse:
                with torch.no_grad():
                    old = (r.tau - r.mu_old) ** 2 / (2 * r.std**2)
                    w = torch.exp(torch.clamp(old - sq, max=0.0))
                sq = w * sq
            loss = loss + (r.adv[:, None] * sq).sum(-1).mean()
        self.opt_rl.zero_grad()
        loss.backward()
        self.opt_rl.step()

    def update(self, rollouts: list[_Rollout]) -> int:
        """SL, the first RL step on fresh roll-outs, then SL + further RL steps on the same
        roll-outs until the stop rule holds or ``max_reuse``. Returns the further RL steps.

        "awr": stop once the mean is within ``fit_tolerance`` stds of the advantage-weighted
        target at every step (weighted by the step's relevance); "reinforce" (the
        authors' reuse): stop once the mean has moved more than ``reuse_threshold`` stds from the
        one that drew the roll-outs, importance-weighting each reuse.
        """
        awr = self.cfg.advantage == "awr"
        if awr:
            rel = torch.stack([r.adv for r in rollouts]).sum(0)  # (T,) the AWR weights sum to the relevance
            target = sum(r.adv[:, None] * r.tau for r in rollouts) / rel.clamp_min(1e-12)[:, None]
        self.model.train()
        self.sl(self.cfg.sl_steps)
        self.rl(rollouts, reuse=False)
        reuses = 0
        while reuses < self.cfg.max_reuse:
            self.sl(self.cfg.sl_steps_reuse)
            mu = self.mean()
            if awr:
                if float((rel[:, None] * (mu - target).abs() / rollouts[0].std).max()) < self.cfg.fit_tolerance:
                    break
            elif max(float(((mu - r.mu_old).abs() / r.std).max()) for r in rollouts) > self.cfg.reuse_threshold:
                break
            self.rl(rollouts, reuse=not awr)
            reuses += 1
        self.model.eval()
        return reuses


def _evaluate(evaluator: RolloutEvaluator, trajs: np.ndarray, times: np.ndarray, tp) -> RolloutBatch:
    """Run ``trajs`` (B, T, D) raw and check that B roll-outs came back."""
    batch = evaluator.evaluate(trajs, times, tp)
    if len(batch) != len(trajs):
        raise ValueError(f"evaluator: expected {len(trajs)} roll-outs back, got {len(batch)}")
    return batch


def _demos_on(demos: DemoSet, times: np.ndarray, model: CNMP) -> np.ndarray:
    """(N, T, D) the demonstrations, normalised as ``model``'s outputs, at ``times`` (T,) of their
    phase (each demonstration's times mapped onto [times[0], times[-1]])."""
    out = []
    for d in demos.demos:
        ph = (d.times - d.times[0]) / (d.times[-1] - d.times[0]) * (times[-1] - times[0]) + times[0]
        out.append(np.stack([np.interp(times, ph, d.values[:, j]) for j in range(d.values.shape[1])], axis=1))
    with torch.no_grad():
        return model.value_norm.normalize(torch.as_tensor(np.stack(out), dtype=torch.float32)).double().numpy()


@with_training_threads
def adapt(
    model: CNMP,
    demos: DemoSet,
    target: AdaptTarget,
    evaluator: RolloutEvaluator,
    cfg: AdaptConfig | None = None,
    *,
    seed: int = 0,
    train_cfg: TrainConfig | None = None,
    on_iteration: Callable[[IterationLog, np.ndarray, RolloutBatch], None] | None = None,
    params: Iterable[torch.nn.Parameter] | None = None,
) -> AdaptResult:
    """Adapt ``model`` in place so that its output for ``target`` maximises the evaluator's reward.

    Parameters
    ----------
    model : a trained CNMP (its normalisation is kept).
    demos : the demonstrations for the interleaved supervised steps (raw units).
    target : the conditioning query to adapt.
    evaluator : executes trajectories (B, T, D) at ``target.query_times``; see RolloutEvaluator.
    cfg : :class:`AdaptConfig`. seed : seeds exploration and supervised sampling.
    train_cfg : episode sampling for the supervised steps (defaults to TrainConfig()).
    on_iteration : called after each iteration with (log, executed trajectories (1+K, T, D) raw,
        RolloutBatch); services use it to record every roll-out.
    params : the parameters the RL and SL steps train (default: all of ``model``'s); e.g. one
        robot's decoder when adapting a transferred skill (:mod:`acnmp_core.transfer.pair`). The others
        keep their values, their gradients are computed but never applied.

    Returns an :class:`AdaptResult` whose ``trajectory`` is the model's mean for ``target`` at the end.
    """
    cfg = cfg or AdaptConfig()
    train_cfg = train_cfg or TrainConfig()
    query = target.query(model)
    times = query.times
    tp = None if target.task_params is None else np.asarray(target.task_params, dtype=np.float64)
    d = model.config.n_outputs
    scale = model.value_norm.scale.double().numpy()
    std0 = cfg.explore_scale * np.ones(d)  # normalised units: the demos' std is 1
    rng = np.random.default_rng(seed)
    gen = torch.Generator().manual_seed(seed)
    n_knots = min(cfg.n_knots, len(times))
    if cfg.noise == "demos":
        noise = DemoNoise(_demos_on(demos, times, model))
    else:
        noise = CubicNoise(len(times), n_knots) if cfg.noise == "cubic" else SmoothNoise(len(times), n_knots)
    updater = _Updater(model, query, cfg, demos, train_cfg, gen, None if params is None else list(params))
    # One draw of demonstration-shaped noise perturbs the whole trajectory at once: its return is its credit.
    credit = "episode" if cfg.noise == "demos" else getattr(evaluator, "credit", "step")
    history: list[IterationLog] = []
    rollouts, it, success, err0 = 0, 0, False, None
    solved: int | None = None  # the row, in the last batch, of the roll-out that is the solution
    model.eval()

    def denorm(x: np.ndarray) -> np.ndarray:
        return model.value_norm.denormalize(torch.as_tensor(x)).numpy()

    while rollouts < cfg.max_rollouts:
        mu_t = updater.mean()
        mu = mu_t.double().numpy()  # (T, D)
        k = 0 if cfg.mode == "lfd_only" else min(cfg.noisy_per_iter, cfg.max_rollouts - rollouts - 1)
        std = explore_std(cfg, std0, scale, history[-1].mean_error if history else None, err0)
        eps = noise.sample(k, d, rng, std) if k else np.zeros((0, len(times), d))
        trajs_n = np.concatenate([mu[None], mu[None] + eps])
        trajs = denorm(trajs_n)
        if k and cfg.stop_on_success and (it == 0 or cfg.mean_first):
            # The mean runs alone first (the first mean is the LfD trajectory): a mean that
            # succeeds costs one roll-out, and no exploration is executed after it.
            batch = _evaluate(evaluator, trajs[:1], times, tp)
            if batch.success[0]:
                trajs, k = trajs[:1], 0
            else:
                batch = RolloutBatch.concat([batch, _evaluate(evaluator, trajs[1:], times, tp)])
        else:
            batch = _evaluate(evaluator, trajs, times, tp)
        rollouts += 1 + k
        errors = batch.remaining_errors()
        if err0 is None:
            err0 = float(errors[0])
        success = bool(batch.success[0])
        solved = 0 if success else None
        if solved is None and cfg.solution == "any" and k and np.any(batch.success[1:]):
            solved = 1 + int(np.argmax(batch.success[1:]))
        log = IterationLog(it, rollouts, float(batch.returns[0]), success, [float(r) for r in batch.returns[1:]],
                           list(map(float, std * scale)), float(errors[0]))
        history.append(log)
        if on_iteration is not None:
            on_iteration(log, trajs, batch)
        it += 1
        if (solved is not None and cfg.stop_on_success) or k == 0:
            break
        found = per_step_advantages(batch.rewards, cfg.advantage, cfg.temperature, credit, cfg.signal_tolerance)
        if found is None:
            continue
        rows, adv = found
        std_t = torch.as_tensor(std, dtype=torch.float32)
        fresh = [_Rollout(torch.as_tensor(trajs_n[j], dtype=torch.float32),
                          torch.as_tensor(a, dtype=torch.float32), std_t, mu_t) for j, a in zip(rows, adv)]
        log.reuses = updater.update(fresh)

    if solved is not None and solved > 0:
        return AdaptResult(success=True, rollouts=rollouts, trajectory=trajs[solved], times=times, history=history,
                           solved_by="noisy", solution_error=float(errors[solved]))
    final = updater.mean().double().numpy()
    return AdaptResult(success=success, rollouts=rollouts, trajectory=denorm(final), times=times,
                       history=history, solved_by="mean" if success else None,
                       solution_error=float(errors[0]) if success else None)
