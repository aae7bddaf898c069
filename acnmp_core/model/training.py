"""Supervised training of a CNMP by Gaussian negative log-likelihood on sampled episodes."""
from __future__ import annotations

import copy
import math
import threading
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import torch
from tqdm.auto import tqdm

from ..data.demos import DemoSet
from ..threads import with_training_threads
from ..validation import check_lr_final, check_positive_int
from .cnmp import CNMP
from .episodes import Episode, EpisodeSampler
from .optim_step import FusedAdam, Stepper, adam


@dataclass
class TrainConfig:
    """Hyper-parameters of supervised training.

    steps : gradient steps. batch_size : episodes per step (each from a random demonstration).
    min_obs, max_obs : observations per episode, uniform in [min_obs, max_obs] (the authors: 1..5).
    n_targets : target points per episode, never among its observations unless
        ``targets_include_obs`` (then the observations are among them; see EpisodeSampler).
    lr : Adam learning rate. val_fraction : share of demonstrations held out for validation; when it
    rounds to zero demonstrations, a fixed set of episodes drawn from the training demonstrations
    is used instead, which still makes best-checkpoint keeping meaningful.
    val_every : steps between validations. partial_obs_prob : see EpisodeSampler.
    beta : beta-NLL exponent for the training loss (see :func:`nll_loss`); 0 is the plain NLL.
    mixup : probability that an episode blends two demonstrations (0: never; see EpisodeSampler).
    task_param_jitter : std (normalised units) of the Gaussian noise added to each episode's task
        parameters (0: none; see EpisodeSampler).
    lr_final : None keeps ``lr`` constant; a number decays the rate from ``lr`` to ``lr_final``
        along a half cosine over the steps (:func:`cosine_lr`), which ends training with small,
        precise steps instead of Adam's full-rate jitter.
    """

    steps: int = 5000
    batch_size: int = 32
    min_obs: int = 1
    max_obs: int = 5
    n_targets: int = 10
    lr: float = 1e-3
    val_fraction: float = 0.0
    val_every: int = 250
    val_episodes: int = 256
    partial_obs_prob: float = 0.2
    beta: float = 0.5
    lr_final: float | None = None
    targets_include_obs: bool = False
    task_param_jitter: float = 0.0
    mixup: float = 0.0

    def __post_init__(self) -> None:
        check_positive_int("steps", self.steps, minimum=0)
        check_positive_int("batch_size", self.batch_size)
        check_positive_int("val_every", self.val_every)
        if not (0.0 <= self.val_fraction < 1.0):
            raise ValueError(f"val_fraction: expected 0 <= val_fraction < 1, got {self.val_fraction}")
        if not (self.lr > 0):
            raise ValueError(f"lr: expected > 0, got {self.lr}")
        check_lr_final(self.lr, self.lr_final)
        j = self.task_param_jitter
        if isinstance(j, bool) or not isinstance(j, (int, float)) or not 0 <= j < float("inf"):
            raise ValueError(f"task_param_jitter: expected a finite std >= 0, got {j!r}")
        if isinstance(self.mixup, bool) or not isinstance(self.mixup, (int, float)) or not 0 <= self.mixup <= 1:
            raise ValueError(f"mixup: expected a probability in [0, 1], got {self.mixup!r}")


def cosine_lr(lr: float, lr_final: float | None, step: int, steps: int) -> float:
    """Learning rate of gradient step ``step`` (1..steps): ``lr`` at the first step, falling along
    a half cosine to ``lr_final`` at the last; ``lr`` throughout when ``lr_final`` is None."""
    if lr_final is None or steps <= 1:
        return lr
    frac = (step - 1) / (steps - 1)
    return lr_final + 0.5 * (lr - lr_final) * (1.0 + math.cos(math.pi * frac))


def set_lr(opt: torch.optim.Optimizer | FusedAdam, lr: float) -> None:
    """Set every parameter group's learning rate of ``opt`` (a float, as the fused Adam wants)."""
    for g in opt.param_groups:
        g["lr"] = float(lr)


@dataclass
class TrainResult:
    """History of a training run: losses per step, validation (step, loss) pairs, the best."""

    train_loss: list[float] = field(default_factory=list)
    val: list[tuple[int, float]] = field(default_factory=list)
    best_step: int = 0
    best_val: float = math.inf


def nll_loss(model: CNMP, ep: Episode, beta: float = 0.0) -> torch.Tensor:
    """Mean Gaussian NLL (per target point and dimension, normalised units) of an episode batch.

    ``beta > 0`` gives the beta-NLL of Seitzer et al. (ICLR 2022): each term is weighted by the
    detached ``std ** (2 beta)``. Without it, an output that is nearly deterministic (std at the
    floor) dominates the shared gradients and the other outputs stop learning; beta = 0.5 balances
    them. The value reported for validation always uses beta = 0 (the true NLL).
    """
    mean, std, _ = model(ep.obs_x, ep.obs_mask, ep.tgt_x)
    var = std**2
    nll = 0.5 * (torch.log(2 * math.pi * var) + (ep.tgt_y.to(mean.device) - mean) ** 2 / var)
    if beta > 0:
        nll = nll * var.detach() ** beta
    return nll.mean()


def make_sampler(model: CNMP, demos: DemoSet, cfg: TrainConfig) -> EpisodeSampler:
    """An EpisodeSampler over ``demos`` packed with ``model``'s normalisation."""
    return EpisodeSampler(
        model.pack(demos),
        min_obs=cfg.min_obs,
        max_obs=cfg.max_obs,
        n_targets=cfg.n_targets,
        partial_obs_prob=cfg.partial_obs_prob,
        targets_include_obs=cfg.targets_include_obs,
        task_param_jitter=cfg.task_param_jitter,
        mixup=cfg.mixup,
    )


def split_demos(demos: DemoSet, val_fraction: float, gen: torch.Generator) -> tuple[DemoSet, DemoSet | None]:
    """Split into (train, validation); validation is None when ``val_fraction`` gives no demo."""
    n_val = int(math.floor(val_fraction * len(demos)))
    if n_val == 0 or len(demos) - n_val < 1:
        return demos, None
    perm = torch.randperm(len(demos), generator=gen).tolist()
    return demos.subset(sorted(perm[n_val:])), demos.subset(sorted(perm[:n_val]))


@with_training_threads
def train(
    model: CNMP,
    demos: DemoSet,
    cfg: TrainConfig | None = None,
    *,
    seed: int = 0,
    fit_normalization: bool = True,
    progress: bool = True,
    optimizer: torch.optim.Optimizer | FusedAdam | None = None,
    stop: threading.Event | None = None,
    on_validation: Callable[[int, float, float], None] | None = None,
    device: str | torch.device | None = None,
) -> TrainResult:
    """Train ``model`` in place on ``demos`` and leave it at its best validation checkpoint.

    Parameters
    ----------
    model : the CNMP; its normalisation is fitted on ``demos`` first unless ``fit_normalization``
        is False (continued training, e.g. after assimilation, keeps the original statistics; the
        range the network sees and the linear path follow ``demos``: :meth:`CNMP.follow_demos`). A
        model whose prior is "auto" has it chosen first from ``demos``
        (:func:`~acnmp_core.model.selection.choose_prior`, which trains its candidates on held-out
        folds of them with this ``cfg``), and its config records the choice.
    demos : the demonstrations (raw units).
    cfg : hyper-parameters; defaults to :class:`TrainConfig`.
    seed : makes the run deterministic (sampling and validation split).
    progress : show a tqdm progress bar (on a terminal only).
    optimizer : continue with an existing optimizer (default: a new one from :func:`~.optim_step.adam`).
    stop : when set (e.g. a service shutting down), InterruptedError at the next step; ``model``
        is then left part-trained, so the caller discards it.
    on_validation : called after each validation but the first as ``(step, mean training loss
        since the previous validation, validation loss)``: a service's loss curve.
    device : move ``model``'s networks there first (``cpu``, ``cuda``, ``auto``; acnmp_core/model/device.py);
        None trains where they are. Not with ``optimizer`` (its state belongs to the old place).

    Returns a :class:`TrainResult`.
    """
    cfg = cfg or TrainConfig()
    if device is not None:
        if optimizer is not None and model.device != torch.device(str(device)):
            raise ValueError("device: give the optimizer of a model already on its device, or no optimizer")
        model.to_device(device)
    if fit_normalization:
        if model.config.prior == "auto":
            from .selection import choose_prior

            choice = choose_prior(demos, model.config, fold_trainer(cfg, seed, stop), seed)
            model.config.prior, model.config.prior_choice = choice.chosen, choice
        model.fit_normalization(demos)
    else:
        model.follow_demos(demos)
    gen = torch.Generator().manual_seed(seed)
    train_set, val_set = split_demos(demos, cfg.val_fraction, gen)
    sampler = make_sampler(model, train_set, cfg)
    val_gen = torch.Generator().manual_seed(seed + 1)
    if val_set is not None:
        val_sampler = make_sampler(model, val_set, cfg)
        val_ep = val_sampler.sample(cfg.val_episodes, val_gen)
    else:
        val_ep = sampler.sample(cfg.val_episodes, val_gen)
    opt = Stepper(optimizer or adam(model.parameters(), lr=cfg.lr))
    result = TrainResult()
    best_state = copy.deepcopy(model.state_dict())
    model.train()

    def validate(step: int) -> None:
        model.eval()
        with torch.no_grad():
            v = float(nll_loss(model, val_ep))
        model.train()
        result.val.append((step, v))
        if v < result.best_val:
            result.best_val, result.best_step = v, step
            best_state.update(copy.deepcopy(model.state_dict()))

    validate(0)
    # disable=None: tqdm draws only on a terminal (no bar lines in a log file or a pipe)
    bar = tqdm(range(1, cfg.steps + 1), desc="train", disable=None if progress else True, leave=False)
    for step in bar:
        check_stop(stop, "training")
        loss = nll_loss(model, sampler.sample(cfg.batch_size, gen), cfg.beta)
        opt.zero_grad()
        loss.backward()
        if cfg.lr_final is not None:
            set_lr(opt.opt, cosine_lr(cfg.lr, cfg.lr_final, step, cfg.steps))
        opt.step()
        result.train_loss.append(loss.item())
        if step % cfg.val_every == 0 or step == cfg.steps:
            validate(step)
            bar.set_postfix(nll=f"{result.train_loss[-1]:.3f}", val=f"{result.val[-1][1]:.3f}")
            if on_validation is not None:
                since = result.train_loss[result.val[-2][0]:]
                on_validation(step, float(np.mean(since)), result.val[-1][1])
    model.load_state_dict(best_state)
    model.eval()
    return result


def fold_trainer(cfg: TrainConfig, seed: int,
                 stop: threading.Event | None = None) -> Callable[[CNMP, DemoSet, int], TrainResult]:
    """How the default's choice of model (:func:`~acnmp_core.model.selection.choose_prior`) trains a
    held-out fold's network, one of ``n_fits``: as the skill (``cfg``, ``seed``) for
    :func:`~acnmp_core.model.selection.fold_steps` steps, no progress bar, interrupted as the skill's
    own training by ``stop``."""
    from dataclasses import replace

    from .selection import fold_steps

    return lambda model, demos, n_fits: train(model, demos, replace(cfg, steps=fold_steps(cfg.steps, n_fits)),
                                              seed=seed, progress=False, stop=stop)


def check_stop(stop: threading.Event | None, what: str) -> None:
    """InterruptedError naming ``what`` when ``stop`` is set (no-op for None)."""
    if stop is not None and stop.is_set():
        raise InterruptedError(f"{what} stopped: asked to stop")


def evaluate_nll(model: CNMP, demos: DemoSet, *, episodes: int = 512, seed: int = 123, max_obs: int = 5) -> float:
    """Mean NLL of ``model`` on fixed random episodes from ``demos`` (lower is better)."""
    cfg = TrainConfig(max_obs=max_obs, partial_obs_prob=0.0)
    ep = make_sampler(model, demos, cfg).sample(episodes, torch.Generator().manual_seed(seed))
    with torch.no_grad():
        return float(nll_loss(model, ep))


def reproduction_error(model, demos: DemoSet, *, n_obs: int = 3) -> float:
    """RMS error (raw units) of each demo reproduced from ``n_obs`` of its own points, spread in time.

    ``model`` is a :class:`CNMP` or anything with :meth:`CNMP.predict`'s signature and result
    (e.g. a skill served by a deployment)."""
    errs = []
    for d in demos:
        idx = np.linspace(0, len(d.times) - 1, n_obs).round().astype(int)
        pred = model.predict(d.times[idx], d.values[idx], d.task_params, d.times)
        errs.append(np.mean((pred.mean - d.values) ** 2))
    return float(np.sqrt(np.mean(errs)))
