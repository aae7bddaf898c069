"""A baseline after Ewerton et al. 2019 ("Learning trajectory distributions for assisted teleoperation
and path planning", Frontiers in Robotics and AI 6:89): ProMPs improved by relevance-weighted
policy optimisation (PRO) in each environment, generalised over environments by Gaussian-process
regression from the environment to the trajectory distribution.

Two parts:

* :class:`GPWeights`: GP regression from task parameters (P,) to ProMP weights (W,), fitted to every
  environment solved so far (the demonstrations first). Its posterior mean is the generated
  trajectory's weights for a new environment and the initial mean of PRO there. Squared-exponential
  kernel on the task parameters scaled by their spread over the library, one kernel for all
  weights, centred on the library's mean, signal variance the weights' spread; the length and the
  noise are chosen once, on the demonstrations, by the smallest leave-one-out error over a grid
  (:func:`fit_gp`; the paper's choice of hyper-parameters is not known to us, the grid is ours).
* :func:`pro`: PRO in one environment. Each iteration draws ``n_samples`` weight vectors from the
  search distribution N(mu, Sigma) and executes them; ``objectives`` splits each roll-out's reward
  into O objectives (E3: start error, clearance, goal error). The *relevance* of weight ``n`` to
  objective ``o`` is the absolute Pearson correlation, over the samples, between that weight and that
  objective's reward, divided by its largest value over the weights (:func:`relevance`). Each weight
  then has its own sample weights ``d_in ∝ exp(beta * sum_o f_on * r~_oi)``, ``r~`` the objective's
  rewards rescaled to [0, 1] over the samples; the new mean of weight ``n`` is ``sum_i d_in w_in``
  and its new variance the ``d_in``-weighted variance about it (floored at ``min_std**2``); the
  correlations between weights are kept from the previous covariance (:func:`pro_update`). A weight
  that matters to no objective keeps almost uniform sample weights and barely moves, which is the
  point of the relevance: each objective only moves the parameters that affect it. Where the paper
  is not at hand in full, the normalisations and the covariance's treatment are our guesses (see
  benchmarks/studies/e3_wall/README.md, "Baseline after Ewerton et al.").

The loop (the mean's roll-out before every iteration, stop on its success or at the budget, every
roll-out counted) is :func:`~acnmp_core.baselines.promp_rl.episodic_search`, shared with ProMP + REPS.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..rollout import RolloutBatch, RolloutEvaluator
from ..validation import check_array, check_positive_int
from .promp import ProMP
from .promp_rl import PrompRLResult, episodic_search

#: Splits executed roll-outs into per-objective rewards: RolloutBatch (B roll-outs) -> (B, O).
Objectives = Callable[[RolloutBatch], np.ndarray]


def total_return(batch: RolloutBatch) -> np.ndarray:
    """The default single objective: each roll-out's return, (B, 1)."""
    return batch.returns[:, None]


@dataclass
class SelfImproveConfig:
    """Settings of the Ewerton-style baseline.

    n_samples : roll-outs drawn per PRO iteration (>= 2).
    max_rollouts : budget per environment, the mean's roll-outs included.
    beta : inverse temperature on objective rewards rescaled to [0, 1].
    init_cov_scale : PRO's initial covariance is the library's weight covariance times this ...
    min_std : ... plus ``min_std**2`` on the diagonal; also the floor of every weight's std.
    lengthscale : GP kernel length in units of each task parameter's spread over the library;
        None: chosen on the demonstrations by :func:`fit_gp`.
    noise : GP noise variance relative to the signal variance; None: as ``lengthscale``.
    seed : seeds PRO's sampling.
    """

    n_samples: int = 20
    max_rollouts: int = 1000
    beta: float = 10.0
    init_cov_scale: float = 0.1
    min_std: float = 0.01
    lengthscale: float | None = None
    noise: float | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        check_positive_int("n_samples", self.n_samples, minimum=2)
        check_positive_int("max_rollouts", self.max_rollouts)
        for name in ("beta", "lengthscale", "noise"):
            if getattr(self, name) is not None and not getattr(self, name) > 0:
                raise ValueError(f"{name}: expected a positive number, got {getattr(self, name)}")
        if self.min_std < 0 or self.init_cov_scale < 0:
            raise ValueError("min_std, init_cov_scale: expected non-negative numbers")


class GPWeights:
    """GP regression from task parameters to ProMP weights (the posterior mean only).

    task_params : (N, P) environments; weights : (N, W) their solutions' ProMP weights;
    lengthscale, noise : as in :class:`SelfImproveConfig`.
    """

    def __init__(self, task_params, weights, *, lengthscale: float = 1.0, noise: float = 1e-2) -> None:
        x = check_array("task_params", task_params, ndim=2, min_size=1)
        y = check_array("weights", weights, ndim=2)
        if y.shape[0] != x.shape[0]:
            raise ValueError(f"weights: expected {x.shape[0]} rows (one per environment), got {y.shape[0]}")
        spread = x.std(axis=0)
        self._scale = lengthscale * np.where(spread > 0, spread, 1.0)
        self._x = x / self._scale
        self._mean = y.mean(axis=0)
        yc = y - self._mean
        self._s2 = s2 = max(float(np.mean(yc**2)), 1e-12)  # signal variance: the weights' spread
        k = s2 * (self._kernel(self._x) + noise * np.eye(len(x)))
        k_inv = np.linalg.inv(k)
        self._alpha = k_inv @ yc  # (N, W)
        self._loo = float(np.mean((self._alpha / np.diag(k_inv)[:, None]) ** 2))

    def loo_error(self) -> float:
        """Mean squared leave-one-out error of the weights (closed form, Rasmussen and Williams
        2006, Sec. 5.4.2: ``[K^-1 y]_i / [K^-1]_ii``): smaller is a better choice of hyper-parameters."""
        return self._loo

    def _kernel(self, a: np.ndarray) -> np.ndarray:
        d2 = np.sum(a**2, 1)[:, None] + np.sum(self._x**2, 1)[None] - 2 * a @ self._x.T
        return np.exp(-0.5 * np.maximum(d2, 0.0))

    def predict(self, task_params) -> np.ndarray:
        """Posterior mean weights (B, W) for task parameters (B, P)."""
        c = check_array("task_params", task_params, ndim=2, shape=(None, self._x.shape[1]))
        return self._mean + self._s2 * self._kernel(c / self._scale) @ self._alpha


def fit_gp(task_params, weights, lengthscales=(1.0, 2.0, 3.0, 5.0, 10.0, 20.0),
           noises=(1e-4, 1e-3, 1e-2, 1e-1)) -> tuple[float, float]:
    """The (lengthscale, noise) of the grid with the smallest leave-one-out error of ``weights``
    (N, W) given ``task_params`` (N, P) (:meth:`GPWeights.loo_error`)."""
    best = min((GPWeights(task_params, weights, lengthscale=ls, noise=nz).loo_error(), ls, nz)
               for ls in lengthscales for nz in noises)
    return best[1], best[2]


def relevance(weights, objectives) -> np.ndarray:
    """Relevance of each weight to each objective, (O, W) in [0, 1].

    weights : (N, W) sampled weight vectors; objectives : (N, O) their per-objective rewards.
    ``|corr(w_n, r_o)|`` over the N samples, divided by its largest value over n (so the most
    relevant weight of an objective has 1); 0 where a weight or an objective does not vary.
    """
    w = check_array("weights", weights, ndim=2)
    r = check_array("objectives", objectives, ndim=2, shape=(w.shape[0], None))
    wc, rc = w - w.mean(0), r - r.mean(0)
    ws, rs = np.sqrt((wc**2).sum(0)), np.sqrt((rc**2).sum(0))
    denom = np.outer(rs, ws)
    corr = np.abs(np.divide(rc.T @ wc, denom, out=np.zeros_like(denom), where=denom > 0))
    top = corr.max(axis=1, keepdims=True)
    return np.divide(corr, top, out=np.zeros_like(corr), where=top > 0)


def pro_update(cov, weights, objectives, *, beta: float, min_std: float) -> tuple[np.ndarray, np.ndarray]:
    """One PRO update of the search distribution (module docstring).

    cov : (W, W) the current covariance (its correlations are kept); weights : (N, W) the samples;
    objectives : (N, O) their per-objective rewards (higher is better). Returns the new mean (W,)
    and covariance (W, W).
    """
    w = check_array("weights", weights, ndim=2)
    r = check_array("objectives", objectives, ndim=2, shape=(w.shape[0], None))
    span = r.max(0) - r.min(0)
    r01 = np.divide(r - r.min(0), span, out=np.zeros_like(r), where=span > 0)  # (N, O)
    logits = beta * r01 @ relevance(w, r)  # (N, W): sample i's score for weight n
    d = np.exp(logits - logits.max(axis=0))
    d /= d.sum(axis=0)
    mean = (d * w).sum(axis=0)
    std = np.sqrt(np.maximum((d * (w - mean) ** 2).sum(axis=0), min_std**2))
    old_std = np.sqrt(np.clip(np.diag(cov), 1e-300, None))
    corr = cov / np.outer(old_std, old_std)
    new = corr * np.outer(std, std)
    return mean, (new + new.T) / 2


def pro(init: ProMP, evaluator: RolloutEvaluator, times, task_params=None,
        config: SelfImproveConfig | None = None, objectives: Objectives = total_return) -> PrompRLResult:
    """PRO over ProMP weights from the search distribution ``init`` in one environment.

    init : the initial ProMP (mean, covariance); evaluator : executes (B, T, D) trajectories at
    ``times`` (T,) for ``task_params`` (P,); config : :class:`SelfImproveConfig`; objectives : splits
    roll-outs into per-objective rewards (default: one objective, the return). Returns a
    :class:`~acnmp_core.baselines.promp_rl.PrompRLResult` (every roll-out counted, the mean's too).
    """
    cfg = config if config is not None else SelfImproveConfig()

    def update(mean, cov, w, samples):
        return pro_update(cov, w, objectives(samples), beta=cfg.beta, min_std=cfg.min_std)

    return episodic_search(init, evaluator, times, task_params, n_samples=cfg.n_samples,
                           max_rollouts=cfg.max_rollouts, seed=cfg.seed, update=update)


def initial_distribution(promp: ProMP, gp: GPWeights, task_params, config: SelfImproveConfig) -> ProMP:
    """PRO's start in a new environment: the GP's mean weights for ``task_params`` (P,) and the
    library's weight covariance ``promp.weight_cov`` times ``init_cov_scale`` plus ``min_std**2``."""
    c = check_array("task_params", task_params, ndim=1)
    cov = config.init_cov_scale * promp.weight_cov + config.min_std**2 * np.eye(promp.n_weights)
    return promp.with_distribution(gp.predict(c[None])[0], (cov + cov.T) / 2)
