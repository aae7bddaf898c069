"""Adaptive ProMP + episodic RL over the ProMP weights: the baseline ACNMP is compared with (E2).

Initialisation follows Stark et al. 2019 (experience reuse with ProMPs): the search distribution
for a new task starts from the closest learnt skill,

* ``init="nearest"`` (default): mean = the weights of the demonstration whose task parameters are
  nearest the new ones (Euclidean distance after scaling each parameter by its spread over the
  demos); covariance = the demonstrations' weight covariance times ``init_cov_scale``, plus
  ``min_std**2`` on the diagonal;
* ``init="conditional"``: a joint Gaussian over (weights, task parameters) fitted to the demos and
  conditioned on the new task parameters, i.e. linear regression from task to weights;
* ``init="similar"`` (Stark et al.'s first transfer): mean = the weights of the demonstration whose
  *effect* (e.g. the pushed object's final position, ``effects``) is nearest the desired effect (the
  new task parameters, in the same units); covariance as for "nearest";
* ``init="mixture"`` (Stark et al.'s second transfer): a similarity-weighted mixture of the
  demonstrated skills, moment-matched to one Gaussian: similarities ``s_i = exp(-d_i^2 / (2 h^2))``
  of the effect distances ``d_i``, bandwidth ``h`` the nearest effect's distance (a guess: the
  paper's kernel is not given); mean ``sum s_i w_i / sum s_i``; covariance the skills' spread about
  it, ``sum s_i (w_i - mean)(w_i - mean)^T / sum s_i``, plus each skill's own covariance (as for
  "nearest");
* ``init="scratch"`` (no experience): mean = the weights that hold the demonstrations' common start
  posture (the robot's current state, not a skill), covariance ``scratch_std**2 * I`` (rad^2 for
  joint trajectories), a broad isotropic prior.

The RL is episodic: every iteration draws ``n_samples`` weight vectors from the search
distribution N(mu, Sigma), executes their trajectories, and re-weights them by return.

* ``method="reps"`` (default): episodic REPS (Peters et al. 2010; Deisenroth et al. 2013,
  "A survey on policy search", Sec. 2.4.2): weights ``exp(R / eta)`` with the temperature ``eta``
  from REPS's dual, so the new sample distribution stays within KL ``epsilon`` of the old one.
* ``method="rwr"``: reward-weighted regression with ``exp(beta * (R - max R) / (max R - min R))``.

The mean moves to the weighted mean of the samples. The covariance (``cov_update``):

* "cma" (default, the project's tuned variant): moves towards the samples' weighted covariance about
  the old mean with rate ``cov_rate`` (a CMA-ES-style rank-mu update), plus a ``min_std**2`` floor:
  with fewer samples per iteration than weights, the plain weighted maximum-likelihood covariance
  would be singular and exploration would collapse after one iteration;
* "wml": plain weighted maximum likelihood, the samples' weighted covariance about the new mean
  (REPS's closed-form M-step, as in Stark et al. 2019), plus the ``min_std**2`` floor as regulariser.

Roll-outs go only through :class:`~acnmp_core.rollout.RolloutEvaluator`. Each iteration first
evaluates the current mean trajectory (one roll-out) and stops if it succeeds; the stopping criterion
is that success, or the roll-out budget ``max_rollouts``. Every roll-out, including those of the
mean, counts in ``n_rollouts``. Deterministic for a given ``seed`` and a deterministic evaluator.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..rollout import RolloutBatch, RolloutEvaluator
from ..validation import check_array, check_positive_int
from .promp import ProMP, _demo_lists


#: Initialisations of the search distribution (module docstring).
INITS = ("nearest", "conditional", "similar", "mixture", "scratch")


@dataclass
class PrompRLConfig:
    """Settings of :func:`promp_rl` (see the module docstring for the algorithms).

    Attributes
    ----------
    method : "reps" or "rwr".
    n_samples : exploration roll-outs per iteration.
    max_rollouts : budget; the run stops before exceeding it.
    epsilon : REPS's KL bound per iteration.
    beta : RWR's inverse temperature on returns normalised to [0, 1].
    cov_rate : step size of the covariance update in [0, 1] (0 keeps the initial covariance).
    min_std : floor of the exploration standard deviation per weight (units of the trajectory).
    init : "nearest", "conditional", "similar", "mixture" or "scratch".
    init_cov_scale : multiplies the demonstrations' weight covariance at initialisation.
    cov_update : "cma" or "wml" (module docstring).
    scratch_std : std per weight of the "scratch" prior (units of the trajectory).
    seed : seeds the sampling.
    """

    method: str = "reps"
    n_samples: int = 10
    max_rollouts: int = 2000
    epsilon: float = 0.5
    beta: float = 10.0
    cov_rate: float = 0.3
    min_std: float = 0.01
    init: str = "nearest"
    init_cov_scale: float = 0.1
    cov_update: str = "cma"
    scratch_std: float = 0.3
    seed: int = 0

    def __post_init__(self) -> None:
        if self.method not in ("reps", "rwr"):
            raise ValueError(f"method: expected 'reps' or 'rwr', got {self.method!r}")
        if self.init not in INITS:
            raise ValueError(f"init: expected one of {', '.join(INITS)}, got {self.init!r}")
        if self.cov_update not in ("cma", "wml"):
            raise ValueError(f"cov_update: expected 'cma' or 'wml', got {self.cov_update!r}")
        if not self.scratch_std > 0:
            raise ValueError(f"scratch_std: expected a positive number, got {self.scratch_std}")
        check_positive_int("n_samples", self.n_samples, minimum=2)
        check_positive_int("max_rollouts", self.max_rollouts)
        for name in ("epsilon", "beta"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}: expected a positive number, got {getattr(self, name)}")
        if not 0.0 <= self.cov_rate <= 1.0:
            raise ValueError(f"cov_rate: expected a number in [0, 1], got {self.cov_rate}")
        if self.min_std < 0 or self.init_cov_scale < 0:
            raise ValueError("min_std, init_cov_scale: expected non-negative numbers")


@dataclass
class PrompRLResult:
    """Outcome of :func:`promp_rl`.

    Attributes
    ----------
    success : whether the final mean trajectory succeeded.
    n_rollouts : every roll-out executed (exploration and mean evaluations).
    n_iterations : RL updates performed.
    trajectory : (T, D) the final mean trajectory.
    times : (T,) its times.
    final_return : return of ``trajectory``.
    learning_curve : (I + 1,) return of the mean trajectory at each evaluation (before each update
        and at the end).
    error_curve : (I + 1,) the task's remaining error of the mean trajectory at each evaluation
        (:meth:`RolloutBatch.remaining_errors`).
    rollouts_at : (I + 1,) cumulative roll-outs when each ``learning_curve`` entry was measured.
    sample_returns : (I,) average return of each iteration's exploration roll-outs.
    promp : the final search distribution as a :class:`ProMP`.
    final_states : states of the final mean roll-out (evaluator-specific, each (T, ...)).
    """

    success: bool
    n_rollouts: int
    n_iterations: int
    trajectory: np.ndarray
    times: np.ndarray
    final_return: float
    learning_curve: np.ndarray
    error_curve: np.ndarray
    rollouts_at: np.ndarray
    sample_returns: np.ndarray
    promp: ProMP
    final_states: dict[str, np.ndarray] = field(default_factory=dict)


class AdaptiveProMP:
    """A library of demonstrated skills (one ProMP over all demos, plus each demo's weights) that
    initialises the search distribution for a new task (Stark et al. 2019).

    Parameters
    ----------
    times : N arrays (T_i,) or (N, T); values : N arrays (T_i, D) or (N, T, D).
    task_params : (N, P) task parameters of the demos.
    effects : (N, P) what each demo achieved, in the units of the task parameters (E2: the cylinder's
        final position, m), for the "similar" and "mixture" initialisations; None if unknown.
    n_basis, ridge, kwargs : passed to :meth:`ProMP.from_demos`.
    """

    def __init__(self, times, values, task_params, *, effects=None, n_basis: int = 20, **kwargs) -> None:
        ts, ys = _demo_lists(times, values)
        self.task_params = check_array("task_params", task_params, ndim=2)
        if self.task_params.shape[0] != len(ys):
            raise ValueError(f"task_params: expected {len(ys)} rows (one per demonstration), "
                             f"got {self.task_params.shape[0]}")
        self.effects = None if effects is None else check_array("effects", effects, shape=self.task_params.shape)
        ridge = kwargs.get("ridge", 1e-6)
        self.promp = ProMP.from_demos(ts, ys, n_basis=n_basis, **kwargs)
        if kwargs.get("normalize_duration"):
            ts = [(t - t[0]) / (t[-1] - t[0]) for t in ts]
        self.demo_weights = np.stack([self.promp.weights_from_trajectory(t, y, ridge=ridge) for t, y in zip(ts, ys)])
        spread = self.task_params.std(axis=0)
        self._scale = np.where(spread > 0, spread, 1.0)
        # "scratch" holds the posture every demo starts from: the robot's state, not a skill.
        self.start_weights = self.promp.weights_from_trajectory(ts[0], np.tile(ys[0][0], (len(ts[0]), 1)), ridge=ridge)

    def nearest(self, task_params) -> int:
        """Index of the demonstration whose task parameters are closest (per-parameter scaled)."""
        c = check_array("task_params", task_params, shape=(self.task_params.shape[1],))
        return int(np.argmin(np.linalg.norm((self.task_params - c) / self._scale, axis=1)))

    def effect_similarities(self, task_params) -> np.ndarray:
        """(N,) similarity in (0, 1) of each demo's effect to the desired effect ``task_params`` (P,):
        ``exp(-d_i^2 / (2 h^2))``, d_i the Euclidean distances, h the smallest of them (floored at
        1e-9), so the most similar skill has exp(-1/2). ValueError when the library has no effects."""
        if self.effects is None:
            raise ValueError("effects: the 'similar' and 'mixture' initialisations need the demos' effects")
        c = check_array("task_params", task_params, shape=(self.task_params.shape[1],))
        d = np.linalg.norm(self.effects - c, axis=1)
        h = max(float(d.min()), 1e-9)
        return np.exp(-0.5 * (d / h) ** 2)

    def initial_promp(self, task_params, *, init: str = "nearest", cov_scale: float = 0.1,
                      min_std: float = 0.01, scratch_std: float = 0.3) -> ProMP:
        """The search distribution for a new task ``task_params`` (P,) as a ProMP (see the module
        docstring for ``init``); ``cov_scale`` multiplies the demos' weight covariance, ``min_std``
        and ``scratch_std`` are stds per weight (units of the trajectory)."""
        c = check_array("task_params", task_params, shape=(self.task_params.shape[1],))
        nw = self.promp.n_weights
        floor = min_std**2 * np.eye(nw)
        skill_cov = cov_scale * self.promp.weight_cov + floor
        if init == "nearest":
            mean, cov = self.demo_weights[self.nearest(c)], skill_cov
        elif init == "similar":
            mean, cov = self.demo_weights[int(np.argmax(self.effect_similarities(c)))], skill_cov
        elif init == "mixture":
            s = self.effect_similarities(c)
            s = s / s.sum()
            mean = s @ self.demo_weights
            diff = self.demo_weights - mean
            cov = (s[:, None] * diff).T @ diff + skill_cov
        elif init == "scratch":
            mean, cov = self.start_weights.copy(), scratch_std**2 * np.eye(nw)
        elif init == "conditional":
            # Joint Gaussian over z = [w, c]; condition on c (regularised so few demos still work).
            z = np.hstack([self.demo_weights, self.task_params])
            mu = z.mean(axis=0)
            s = np.cov(z, rowvar=False, ddof=1) if len(z) > 1 else np.zeros((z.shape[1], z.shape[1]))
            s = np.atleast_2d(s) + 1e-6 * np.eye(z.shape[1])
            sww, swc, scc = s[:nw, :nw], s[:nw, nw:], s[nw:, nw:]
            gain = np.linalg.solve(scc, swc.T).T
            mean = mu[:nw] + gain @ (c - mu[nw:])
            cov = cov_scale * (sww - gain @ swc.T) + floor
        else:
            raise ValueError(f"init: expected one of {', '.join(INITS)}, got {init!r}")
        return self.promp.with_distribution(mean, (cov + cov.T) / 2)


def _reps_weights(returns: np.ndarray, epsilon: float) -> np.ndarray:
    """Episodic REPS sample weights: exp((R - max R) / eta), eta minimising the dual
    g(eta) = eta * epsilon + eta * log mean exp((R - max R) / eta)."""
    r = returns - returns.max()
    scale = max(float(np.std(returns)), 1e-12)

    def dual(log_eta: float) -> float:
        eta = np.exp(log_eta)
        return eta * epsilon + eta * np.log(np.mean(np.exp(r / eta)))

    # Golden-section search for log(eta) over a wide bracket around the returns' scale: the dual is
    # convex in eta (and unimodal in log eta), and this keeps scipy out of the dependencies.
    lo, hi = np.log(scale) - 12.0, np.log(scale) + 12.0
    g = (np.sqrt(5.0) - 1.0) / 2.0
    a, b = hi - g * (hi - lo), lo + g * (hi - lo)
    fa, fb = dual(a), dual(b)
    for _ in range(80):
        if fa < fb:
            hi, b, fb = b, a, fa
            a = hi - g * (hi - lo)
            fa = dual(a)
        else:
            lo, a, fa = a, b, fb
            b = lo + g * (hi - lo)
            fb = dual(b)
    w = np.exp(r / np.exp((lo + hi) / 2.0))
    return w / w.sum()


def _rwr_weights(returns: np.ndarray, beta: float) -> np.ndarray:
    span = max(float(returns.max() - returns.min()), 1e-12)
    w = np.exp(beta * (returns - returns.max()) / span)
    return w / w.sum()


#: An update of the search distribution: (mean (W,), cov (W, W), sampled weights (N, W), their
#: executed RolloutBatch) -> (new mean, new cov).
SearchUpdate = Callable[[np.ndarray, np.ndarray, np.ndarray, RolloutBatch], tuple[np.ndarray, np.ndarray]]


def episodic_search(init: ProMP, evaluator: RolloutEvaluator, times, task_params, *, n_samples: int,
                    max_rollouts: int, seed: int, update: SearchUpdate) -> PrompRLResult:
    """The episodic loop shared by the ProMP baselines, with the update of the distribution left to
    ``update``.

    Each iteration evaluates the mean trajectory (one roll-out) and stops on its success; otherwise
    it draws ``n_samples`` weight vectors from N(mean, cov) (a ``default_rng(seed)`` generator),
    executes them and calls ``update``. The run stops before the roll-outs would exceed
    ``max_rollouts`` (room is kept for the last mean). init : the initial search distribution;
    times : (T,); task_params : (P,) or None, passed to the evaluator. Returns a :class:`PrompRLResult`.
    """
    t = check_array("times", times, ndim=1, min_size=1)
    rng = np.random.default_rng(seed)
    mean, cov = init.weight_mean.copy(), init.weight_cov.copy()
    curve, errors, at, sample_returns = [], [], [], []
    n_rollouts = 0
    iterations = 0
    promp = init
    while True:
        promp = init.with_distribution(mean, cov)
        traj = promp.mean_trajectory(t)
        batch = evaluator.evaluate(traj[None], t, task_params)
        n_rollouts += 1
        ret = float(batch.returns[0])
        curve.append(ret)
        errors.append(float(batch.remaining_errors()[0]))
        at.append(n_rollouts)
        success = bool(batch.success[0])
        n = min(n_samples, max_rollouts - n_rollouts - 1)  # leave room to evaluate the new mean
        if success or n < 2:
            break
        w = promp.sample_weights(n, rng)
        samples = evaluator.evaluate(promp.trajectories_from_weights(w, t), t, task_params)
        n_rollouts += n
        sample_returns.append(float(samples.returns.mean()))
        mean, cov = update(mean, cov, w, samples)
        iterations += 1
    return PrompRLResult(
        success=success,
        n_rollouts=n_rollouts,
        n_iterations=iterations,
        trajectory=traj,
        times=t,
        final_return=ret,
        learning_curve=np.asarray(curve),
        error_curve=np.asarray(errors),
        rollouts_at=np.asarray(at, dtype=np.int64),
        sample_returns=np.asarray(sample_returns),
        promp=promp,
        final_states={k: v[0] for k, v in batch.states.items()},
    )


def promp_rl(
    init: ProMP,
    evaluator: RolloutEvaluator,
    times,
    task_params=None,
    config: PrompRLConfig | None = None,
) -> PrompRLResult:
    """Episodic RL over ProMP weights from the search distribution ``init``.

    Parameters
    ----------
    init : the initial search distribution (e.g. :meth:`AdaptiveProMP.initial_promp`).
    evaluator : executes trajectories (B, T, D) at ``times`` for ``task_params``.
    times : (T,) times of the executed trajectories.
    task_params : (P,) task parameters passed to the evaluator, or None.
    config : :class:`PrompRLConfig`.

    Returns
    -------
    :class:`PrompRLResult`.
    """
    cfg = config if config is not None else PrompRLConfig()
    floor = cfg.min_std**2 * np.eye(init.n_weights)

    def update(mean, cov, w, samples):
        returns = samples.returns
        d = _reps_weights(returns, cfg.epsilon) if cfg.method == "reps" else _rwr_weights(returns, cfg.beta)
        if cfg.cov_update == "cma":
            diff = w - mean  # about the old mean: the step that produced the good samples is learnt too
            cov_ml = (d[:, None] * diff).T @ diff
            mean = d @ w
            cov = (1 - cfg.cov_rate) * cov + cfg.cov_rate * cov_ml
            cov = (cov + cov.T) / 2 + floor * cfg.cov_rate  # keeps exploration from collapsing
        else:
            mean = d @ w
            diff = w - mean  # weighted maximum likelihood: about the new mean
            cov_ml = (d[:, None] * diff).T @ diff
            cov = (cov_ml + cov_ml.T) / 2 + floor  # regularised: fewer samples than weights
        return mean, cov

    return episodic_search(init, evaluator, times, task_params, n_samples=cfg.n_samples,
                           max_rollouts=cfg.max_rollouts, seed=cfg.seed, update=update)


def adapt_promp(
    demo_times,
    demo_values,
    demo_task_params,
    evaluator: RolloutEvaluator,
    times,
    task_params,
    config: PrompRLConfig | None = None,
    *,
    n_basis: int = 20,
    demo_effects=None,
) -> PrompRLResult:
    """Adaptive ProMP + RL in one call: build the skill library from the demos (``demo_effects``
    (N, P) for the effect-based initialisations), initialise the search distribution for
    ``task_params`` (P,) as ``config.init`` says, and run :func:`promp_rl` on ``evaluator``."""
    cfg = config if config is not None else PrompRLConfig()
    lib = AdaptiveProMP(demo_times, demo_values, demo_task_params, effects=demo_effects, n_basis=n_basis)
    init = lib.initial_promp(task_params, init=cfg.init, cov_scale=cfg.init_cov_scale, min_std=cfg.min_std,
                             scratch_std=cfg.scratch_std)
    return promp_rl(init, evaluator, times, task_params, cfg)
