"""Adaptation of a CNMP to a new condition by policy gradient with simultaneous supervised learning.

This is the "A" of ACNMP (Akbulut et al., CoRL 2020, Sec. 3.2). The network's mean trajectory for
one conditioning query is the mean of a Gaussian policy over trajectories with a hand-set
exploration std. Each iteration executes the mean and ``noisy_per_iter`` noisy trajectories
(time-correlated noise, :class:`~acnmp_core.exploration.SmoothNoise`) through a
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
  samples smoothed into one cubic polynomial per output, :class:`~acnmp_core.exploration.CubicNoise`;
  off by default). An iteration whose roll-outs all returned the same rewards (no
  advantage, nothing to learn) takes no policy step; ``signal_tolerance`` says when rewards count
  as the same: a simulator's contact solver jitters an
  untouched object by micrometres, so rewards that should be equal differ by far less than any real
  effect (E4: about 1e-6 against 1e-2 once the paddle touches the cube).

Ablations: ``mode="rl_only"`` turns the supervised steps off; ``mode="lfd_only"`` executes the
conditioned mean once and does not adapt. The settings were chosen on E1, E2 and E3 together
(docs/experiments/adaptation.md).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Callable, Iterable

import numpy as np
import torch

from .cnmp import CNMP, Query
from .data import DemoSet
from .exploration import CubicNoise, DemoNoise, SmoothNoise
from .optim_step import Stepper
from .threads import with_training_threads
from .rollout import RolloutBatch, RolloutEvaluator
from .training import TrainConfig, make_sampler, nll_loss
from .validation import check_positive_int

MODES = ("acnmp", "rl_only", "lfd_only")
ADVANTAGES = ("awr", "reinforce")
#: Which executed roll-out can be adapt()'s solution (``AdaptConfig.solution``).
SOLUTIONS = ("mean", "any")
#: Shapes of the exploration noise (``AdaptConfig.noise``).
NOISES = ("rbf", "cubic", "demos")
#: How a task's rewards depend on the actions (a class attribute ``credit`` of its evaluator):
#: "step" (the reward at t depends on the state at t only) or "future" (on everything before it);
#: "episode" (the whole return at every step) is set by ``noise="demos"``, not by a task.
CREDITS = ("step", "future", "episode")


@dataclass
class AdaptConfig:
    """Hyper-parameters of adaptation; the defaults are the same for every experiment.

    mode : "acnmp" (RL + SL), "rl_only" (no SL) or "lfd_only" (no adaptation).
    max_rollouts : budget; every executed trajectory counts, the mean roll-outs included.
    noisy_per_iter : noisy roll-outs per iteration (one noise-free mean roll-out is added to each).
    explore_scale : initial exploration std, as a fraction of the demonstrations' std per output.
    explore_min : the std never falls below this fraction of the initial std.
    explore_error_gain, explore_cap : None (the default): the rule above. Both set: the std of every
        output is ``min(explore_error_gain * err, explore_cap)`` in the outputs' raw units (``err``
        the last mean roll-out's error, in the task's units; ``explore_cap`` before the first), the
        rule the authors' E4 uses (3 x error, at most 0.08 rad); ``explore_scale`` and
        ``explore_min`` are then unused.
    signal_tolerance : rewards (after credit, see :func:`per_step_advantages`) that differ from the
        mean roll-out's by no more than this at every step are the same: no signal, no policy step.
        The default 1e-12 is exact equality up to rounding.
    n_knots : knots of the time-correlated exploration noise (fewer: smoother).
    noise : "rbf" (the default: :class:`~acnmp_core.exploration.SmoothNoise`, ``n_knots`` knots, the
        std the same at every step) or "cubic" (the authors' E4 noise,
        :class:`~acnmp_core.exploration.CubicNoise`: the least-squares cubic through ``n_knots``
        >= 4 samples of the std, about 0.42 x it per step on average) or "demos" (a random
        combination of the demonstrations' deviations from their mean,
        :class:`~acnmp_core.exploration.DemoNoise`, its root mean square the std: the outputs move
        together as a change of task parameters moves them; one draw perturbs the whole
        trajectory, so each step is credited with the roll-out's whole return, "episode" credit).
    advantage : "awr" or "reinforce" (the authors'); see the module docstring.
    temperature : of the "awr" weights, relative to the rewards' spread at each step.
    lr : Adam learning rate of the policy steps.
    sl_lr : Adam learning rate of the supervised steps.
    sl_steps : supervised steps before the first policy step on an iteration's roll-outs.
    sl_steps_reuse : supervised steps before each further policy step.
    sl_batch_size : episodes per supervised step.
    max_reuse : at most this many further policy steps on one iteration's roll-outs.
    fit_tolerance : "awr": stop once the mean is within this many stds of the target at every step.
    reuse_threshold : "reinforce": stop once the mean has moved more than this many stds.
    stop_on_success : stop when the solution is found (see ``solution``).
    solution : which executed roll-out can be the solution: "mean" (the default; adapt() stops when
        the mean roll-out succeeds and returns the final mean) or "any" (the first roll-out to
        succeed, the mean or a noisy one, ends the adaptation and is returned: for an evaluator
        that gives a trajectory the same result every time, a noisy roll-out that succeeded is as
        much a solution as the mean; the paper's E6 stops at the roll-out that poured within 30 g).
    """

    mode: str = "acnmp"
    max_rollouts: int = 200
    noisy_per_iter: int = 4
    explore_scale: float = 0.3
    explore_min: float = 0.3
    explore_error_gain: float | None = None
    explore_cap: float | None = None
    signal_tolerance: float = 1e-12
    n_knots: int = 12
    noise: str = "rbf"
    advantage: str = "awr"
    temperature: float = 0.1
    lr: float = 1e-4
    sl_lr: float = 3e-5
    sl_steps: int = 10
    sl_steps_reuse: int = 2
    sl_batch_size: int = 8
    max_reuse: int = 50
    fit_tolerance: float = 0.1
    reuse_threshold: float = 1.0
    stop_on_success: bool = True
    solution: str = "mean"

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"mode: expected one of {MODES}, got {self.mode!r}")
        if self.advantage not in ADVANTAGES:
            raise ValueError(f"advantage: expected one of {ADVANTAGES}, got {self.advantage!r}")
        for name in ("max_rollouts", "noisy_per_iter", "n_knots", "sl_batch_size"):
            check_positive_int(name, getattr(self, name))
        for name in ("sl_steps", "sl_steps_reuse", "max_reuse"):
            check_positive_int(name, getattr(self, name), minimum=0)
        for name in ("explore_scale", "lr", "sl_lr", "reuse_threshold", "temperature", "fit_tolerance",
                     "signal_tolerance"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
                raise ValueError(f"{name}: expected a number > 0, got {value!r}")
        if isinstance(self.explore_min, bool) or not isinstance(self.explore_min, (int, float)) \
                or not 0 < self.explore_min <= 1:
            raise ValueError(f"explore_min: expected 0 < explore_min <= 1, got {self.explore_min!r}")
        absolute = (self.explore_error_gain, self.explore_cap)
        if (absolute[0] is None) != (absolute[1] is None):
            raise ValueError("explore_error_gain, explore_cap: expected both set or both None")
        for name, value in zip(("explore_error_gain", "explore_cap"), absolute):
            if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))
                                      or not value > 0):
                raise ValueError(f"{name}: expected a number > 0 or None, got {value!r}")
        if not isinstance(self.stop_on_success, bool):
            raise ValueError(f"stop_on_success: expected true or false, got {self.stop_on_success!r}")
        if self.noise not in NOISES:
            raise ValueError(f"noise: expected one of {NOISES}, got {self.noise!r}")
        if self.noise == "cubic" and self.n_knots < 4:
            raise ValueError(f"n_knots: expected >= 4 with noise='cubic', got {self.n_knots}")
        if self.solution not in SOLUTIONS:
            raise ValueError(f"solution: expected one of {SOLUTIONS}, got {self.solution!r}")

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
    """One adaptation iteration: roll-outs so far, the mean roll-out's return, error and success,
    the returns of the noisy ones, the exploration std (raw units, (D,)), and how many times the
    iteration's roll-outs were reused after their first update."""

    iteration: int
    rollouts: int
    mean_return: float
    mean_success: bool
    noisy_returns: list[float]
    explore_std: list[float]
    mean_error: float | None = None
    reuses: int = 0


@dataclass
class AdaptResult:
    """Outcome: success, roll-outs used, the solution trajectory (T, D) raw (the final mean, or
    with ``solution="any"`` the noisy roll-out that succeeded), its times (T,), the per-iteration
    log, ``solved_by``: "mean", "noisy" or None (no success), and ``solution_error``: the task's
    remaining error of the returned trajectory when it is an executed solution (else None)."""

    success: bool
    rollouts: int
    trajectory: np.ndarray
    times: np.ndarray
    history: list[IterationLog] = field(default_factory=list)
    solved_by: str | None = None
    solution_error: float | None = None


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
        self.opt_rl = Stepper(torch.optim.Adam(params, lr=cfg.lr, fused=True))
        self.opt_sl = Stepper(torch.optim.Adam(params, lr=cfg.sl_lr, fused=True))

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


def _explore_std(cfg: AdaptConfig, std0: np.ndarray, scale: np.ndarray, err: float | None,
                 err0: float | None) -> np.ndarray:
    """Exploration std (D,) in normalised units for the next iteration. std0 (D,) the initial std
    (normalised), scale (D,) the outputs' normalisation scale (raw = normalised x scale), err the
    last mean roll-out's error and err0 the first (None before the first roll-out)."""
    if cfg.explore_error_gain is not None:
        raw = cfg.explore_cap if err is None else min(cfg.explore_error_gain * err, cfg.explore_cap)
        return raw / scale
    ratio = err / err0 if err is not None and err0 > 0 else 1.0
    return std0 * float(np.clip(ratio, cfg.explore_min, 1.0))


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
        robot's decoder when adapting a transferred skill (:mod:`acnmp_core.transfer`). The others
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
        std = _explore_std(cfg, std0, scale, history[-1].mean_error if history else None, err0)
        eps = noise.sample(k, d, rng, std) if k else np.zeros((0, len(times), d))
        trajs_n = np.concatenate([mu[None], mu[None] + eps])
        trajs = denorm(trajs_n)
        if it == 0 and k and cfg.stop_on_success:
            # The first mean is the LfD trajectory: run it alone, so a target the demonstrations
            # already solve costs one roll-out and no exploration.
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
