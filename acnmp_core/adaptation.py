"""Adaptation of a CNMP to a new condition by policy gradient with simultaneous supervised learning.

This is the "A" of ACNMP (Akbulut et al., CoRL 2020, Sec. 3.2). The network's mean trajectory for
one conditioning query is the mean of a Gaussian policy over whole trajectories; exploration adds
time-correlated noise (:class:`~acnmp_core.exploration.SmoothNoise`). Each iteration executes the
mean and a few noisy trajectories through a :class:`~acnmp_core.rollout.RolloutEvaluator`,
computes advantages against the mean roll-out, and takes gradient steps of the policy-gradient
surrogate on those roll-outs (reused for a few iterations with truncated importance weights),
interleaved with supervised NLL steps on the demonstrations so the skill keeps their shape.

Ablations: ``mode="rl_only"`` turns the supervised steps off; ``mode="lfd_only"`` executes the
conditioned mean once and does not adapt.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Callable, Sequence

import numpy as np
import torch

from .cnmp import CNMP, Query
from .data import DemoSet
from .exploration import SmoothNoise
from .rollout import RolloutEvaluator
from .training import TrainConfig, make_sampler, nll_loss
from .validation import check_array, check_positive_int

MODES = ("acnmp", "rl_only", "lfd_only")
ADVANTAGES = ("episodic", "per_step")


@dataclass
class AdaptConfig:
    """Hyper-parameters of adaptation.

    mode : "acnmp" (RL + SL), "rl_only" (no SL) or "lfd_only" (no adaptation).
    noisy_per_iter : noisy roll-outs per iteration (one noise-free mean roll-out is added to each).
    max_rollouts : budget; every executed trajectory counts, the mean roll-outs included.
    explore_std : exploration std per output dimension in raw units (scalar or (D,)); None uses
        ``explore_scale`` times the demonstrations' std of each dimension.
    adapt_exploration : grow the std by ``explore_up`` when more than 40 % of the noisy roll-outs
        beat the mean, shrink it by ``explore_down`` when fewer than 20 % do (a 1/5th-success rule), within
        [explore_min, explore_max] times the initial std.
    explore_from_return : when set to k, the exploration std (raw units) is k * |return of the
        mean roll-out| (within [explore_min, explore_max] times the initial std) instead of the
        1/5th rule: the authors' rule for rewards that are distances, so exploration is as wide as
        the remaining error.
    n_knots : knots of the time-correlated noise.
    mirrored : draw the noise in antithetic pairs (eps, -eps).
    advantage : "episodic" (return of the noisy roll-out minus that of the mean, credited to every
        step) or "per_step" (the authors': per-step reward difference).
    temperature : of the exponentiated advantage weights, relative to the advantages' range
        (smaller is greedier; see :func:`_weights`).
    lr : Adam learning rate of the adaptation updates.
    rl_steps_per_iter : policy-gradient steps per iteration.
    sl_steps_per_rl_step : supervised steps interleaved after each policy-gradient step (acnmp).
    sl_batch_size : episodes per supervised step.
    is_clip : importance weights are truncated at this value; roll-outs whose weight leaves
        [1/is_clip, is_clip] are no longer reused.
    reuse_iters : how many iterations a roll-out may be reused for.
    stop_on_success : stop when the mean roll-out succeeds.
    """

    mode: str = "acnmp"
    noisy_per_iter: int = 2
    max_rollouts: int = 200
    explore_std: float | Sequence[float] | None = None
    explore_scale: float = 0.3
    adapt_exploration: bool = True
    explore_up: float = 1.3
    explore_down: float = 0.8
    explore_min: float = 0.1
    explore_max: float = 3.0
    explore_from_return: float | None = None
    n_knots: int = 8
    mirrored: bool = True
    advantage: str = "per_step"
    lr: float = 1e-3
    rl_steps_per_iter: int = 60
    sl_steps_per_rl_step: int = 1
    sl_batch_size: int = 8
    temperature: float = 0.03
    is_clip: float = 2.0
    reuse_iters: int = 3
    stop_on_success: bool = True

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode: expected one of {MODES}, got {self.mode!r}")
        if self.advantage not in ADVANTAGES:
            raise ValueError(f"advantage: expected one of {ADVANTAGES}, got {self.advantage!r}")
        check_positive_int("noisy_per_iter", self.noisy_per_iter)
        check_positive_int("max_rollouts", self.max_rollouts)
        check_positive_int("rl_steps_per_iter", self.rl_steps_per_iter, minimum=0)
        check_positive_int("sl_steps_per_rl_step", self.sl_steps_per_rl_step, minimum=0)
        if not self.is_clip > 1.0:
            raise ValueError(f"is_clip: expected > 1, got {self.is_clip}")

    def to_dict(self) -> dict:
        """Plain JSON-ready dict of every field."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "AdaptConfig":
        """Build from a dict of field values (unknown keys are an error naming them)."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"config: unknown AdaptConfig field(s) {', '.join(unknown)}")
        return cls(**d)


@dataclass
class AdaptTarget:
    """What to adapt to: a conditioning query in raw units (see :meth:`CNMP.make_query`).

    obs_times (N,), obs_values (N, D), task_params (P,) or None, query_times (T,),
    obs_dims_mask (N, D) bool or None.
    """

    obs_times: np.ndarray
    obs_values: np.ndarray
    task_params: np.ndarray | None
    query_times: np.ndarray
    obs_dims_mask: np.ndarray | None = None

    def query(self, model: CNMP) -> Query:
        """Validate against ``model`` and build the network query."""
        return model.make_query(
            self.obs_times, self.obs_values, self.task_params, self.query_times, obs_dims_mask=self.obs_dims_mask
        )


@dataclass
class IterationLog:
    """One adaptation iteration: roll-outs so far, the mean roll-out's return and success,
    the returns of the noisy ones, the exploration std (raw units, (D,))."""

    iteration: int
    rollouts: int
    mean_return: float
    mean_success: bool
    noisy_returns: list[float]
    explore_std: list[float]


@dataclass
class AdaptResult:
    """Outcome: success of the final mean, roll-outs used, the final mean trajectory (T, D) raw,
    its times (T,), and the per-iteration log."""

    success: bool
    rollouts: int
    trajectory: np.ndarray
    times: np.ndarray
    history: list[IterationLog] = field(default_factory=list)


def _weights(rewards: np.ndarray, kind: str, temperature: float, kernel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Advantage weights of the roll-outs of one iteration (row 0 is the mean roll-out).

    Returns ``(w, relevance)``: ``w`` (1+K, T) normalised over the roll-outs at each step, and
    ``relevance`` (T,) in [0, 1], how much the reward says about each step.

    The advantage of a roll-out is its reward minus that of the mean roll-out: "episodic" uses the
    returns and credits every step alike; "per_step" uses per-step rewards spread over time by
    ``kernel`` (T, T), the exploration noise's correlation, because the noise at one step also moved
    its correlated neighbours. Weights are ``exp(advantage / (temperature * spread))``. The
    relevance of a step is the spread of its advantages over the largest spread: steps the reward
    does not depend on get no policy-gradient signal at all, so what the network does there is left
    to what it learnt from the demonstrations (ACNMP) or to chance (RL only).
    """
    if kind == "episodic":
        adv = np.repeat((rewards.sum(axis=1) - rewards[0].sum())[:, None], rewards.shape[1], axis=1)
    else:
        adv = (rewards - rewards[0:1]) @ kernel.T
    spread = adv.max(axis=0) - adv.min(axis=0)
    z = (adv - adv.max(axis=0, keepdims=True)) / (temperature * np.maximum(spread, 1e-12))
    w = np.exp(z)
    w /= w.sum(axis=0, keepdims=True)
    return w, spread / max(float(spread.max()), 1e-12)


def adapt(
    model: CNMP,
    demos: DemoSet,
    target: AdaptTarget,
    evaluator: RolloutEvaluator,
    cfg: AdaptConfig | None = None,
    *,
    seed: int = 0,
    train_cfg: TrainConfig | None = None,
    on_iteration: Callable[[IterationLog, np.ndarray, "object"], None] | None = None,
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

    Returns an :class:`AdaptResult`.
    """
    cfg = cfg or AdaptConfig()
    train_cfg = train_cfg or TrainConfig()
    query = target.query(model)
    times = query.times
    tp = None if target.task_params is None else np.asarray(target.task_params, dtype=np.float64)
    d = model.config.n_outputs
    scale = model.value_norm.scale.double().numpy()
    if cfg.explore_std is None:
        std0 = cfg.explore_scale * np.ones(d)  # normalised units: the demos' std is 1
    else:
        std0 = check_array("explore_std", cfg.explore_std, ndim=(0, 1)) * np.ones(d) / scale
        if np.any(std0 <= 0):
            raise ValueError("explore_std: expected positive values")
    std = std0.copy()
    rng = np.random.default_rng(seed)
    gen = torch.Generator().manual_seed(seed)
    noise = SmoothNoise(len(times), cfg.n_knots)
    kernel = noise.basis @ noise.basis.T  # (T, T) correlation of the exploration noise
    sampler = make_sampler(model, demos, train_cfg) if cfg.mode == "acnmp" else None
    opt = torch.optim.Adam(model.parameters(), lr=cfg.lr)
    buffer: list[dict] = []
    history: list[IterationLog] = []
    rollouts, it, success = 0, 0, False

    def denorm(x: np.ndarray) -> np.ndarray:
        return model.value_norm.denormalize(torch.as_tensor(x)).numpy()

    while rollouts < cfg.max_rollouts:
        model.eval()
        with torch.no_grad():
            mu = model.mean_normalized(query).double().numpy()  # (T, D)
        k = 0 if cfg.mode == "lfd_only" else min(cfg.noisy_per_iter, cfg.max_rollouts - rollouts - 1)
        if cfg.explore_from_return is not None and it > 0:
            std = np.clip(cfg.explore_from_return * abs(history[-1].mean_return) / scale,
                          cfg.explore_min * std0, cfg.explore_max * std0)
        if cfg.mirrored and k >= 2:
            # Antithetic pairs (eps, -eps): the pair's reward difference is a finite-difference
            # estimate along eps, far less noisy than two independent samples.
            half = noise.sample((k + 1) // 2, d, rng, std)
            eps = np.concatenate([half, -half])[:k]
        else:
            eps = noise.sample(k, d, rng, std)
        trajs_n = np.concatenate([mu[None], mu[None] + eps])
        trajs = denorm(trajs_n)
        batch = evaluator.evaluate(trajs, times, tp)
        if len(batch) != 1 + k:
            raise ValueError(f"evaluator: expected {1 + k} roll-outs back, got {len(batch)}")
        rollouts += 1 + k
        returns = batch.returns
        success = bool(batch.success[0])
        log = IterationLog(it, rollouts, float(returns[0]), success, [float(r) for r in returns[1:]],
                           list(map(float, std * scale)))
        history.append(log)
        if on_iteration is not None:
            on_iteration(log, trajs, batch)
        it += 1
        if (success and cfg.stop_on_success) or k == 0:
            break
        weights, relevance = _weights(batch.rewards, cfg.advantage, cfg.temperature, kernel)
        for j in range(1 + k):
            buffer.append({"tau": trajs_n[j], "adv": weights[j] * relevance, "std": std.copy(),
                           "logp": _logp(mu, trajs_n[j], std), "born": it})
        buffer = [b for b in buffer if it - b["born"] < cfg.reuse_iters]
        if cfg.adapt_exploration and cfg.explore_from_return is None:
            # Rechenberg's 1/5th rule, coarsened for a handful of samples: widen while many noisy
            # roll-outs beat the mean (the optimum is far), narrow when none does (it is near).
            frac = float(np.mean(returns[1:] > returns[0]))
            factor = cfg.explore_up if frac > 0.4 else cfg.explore_down if frac < 0.2 else 1.0
            std = np.clip(std * factor, cfg.explore_min * std0, cfg.explore_max * std0)
        _update(model, opt, query, buffer, cfg, sampler, gen, train_cfg)

    model.eval()
    with torch.no_grad():
        final = denorm(model.mean_normalized(query).double().numpy())
    return AdaptResult(success=success, rollouts=rollouts, trajectory=final, times=times, history=history)


def _logp(mu: np.ndarray, tau: np.ndarray, std: np.ndarray) -> np.ndarray:
    """Per-step log-density (T,) (up to a constant) of tau (T, D) under N(mu, std^2), normalised units."""
    return -0.5 * np.sum(((tau - mu) / std) ** 2, axis=-1)


def _update(model, opt, query, buffer, cfg: AdaptConfig, sampler, gen, train_cfg) -> None:
    """Policy-gradient steps on ``buffer`` interleaved with supervised steps (when ``sampler``)."""
    if not buffer:
        return
    tau = torch.as_tensor(np.stack([b["tau"] for b in buffer]), dtype=torch.float32)  # (N, T, D)
    adv = torch.as_tensor(np.stack([b["adv"] for b in buffer]), dtype=torch.float32)  # (N, T)
    std = torch.as_tensor(np.stack([b["std"] for b in buffer]), dtype=torch.float32)[:, None, :]
    old = torch.as_tensor(np.stack([b["logp"] for b in buffer]), dtype=torch.float32)  # (N, T)
    newest = max(b["born"] for b in buffer)
    fresh = torch.as_tensor([b["born"] == newest for b in buffer])
    model.train()
    for step in range(cfg.rl_steps_per_iter):
        mu = model.mean_normalized(query)  # (T, D)
        z = (tau - mu[None]) / std
        logp_t = -0.5 * (z**2).sum(-1)  # (N, T)
        with torch.no_grad():
            log_ratio = logp_t - old
            if step == 0:
                # Older roll-outs are reused only while the mean has moved little from the one that
                # generated them: their mean per-step log importance ratio stays within log(is_clip).
                reuse = fresh | (log_ratio.mean(-1).abs() <= np.log(cfg.is_clip))
            # Per-step importance weights, truncated at is_clip (per-decision, as in Retrace).
            w = torch.exp(log_ratio.clamp(max=np.log(cfg.is_clip))) * reuse[:, None]
        # Advantage-weighted log-likelihood (AWR, Peng et al. 2019): the policy-gradient surrogate
        # with positive, normalised weights, whose maximiser is the weighted mean of the roll-outs,
        # so repeated steps converge instead of running away as the signed-advantage surrogate does.
        # Multiplying by std^2 makes the step size independent of the exploration std.
        loss = -(w * adv * logp_t).sum() / max(float(w.sum(0).max()), 1e-6) * float((std**2).mean())
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        for _ in range(cfg.sl_steps_per_rl_step if sampler is not None else 0):
            sl = nll_loss(model, sampler.sample(cfg.sl_batch_size, gen), train_cfg.beta)
            opt.zero_grad(set_to_none=True)
            sl.backward()
            opt.step()
    model.eval()
