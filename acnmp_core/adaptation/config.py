"""What an adaptation is asked for and what it gives back: :class:`AdaptConfig` (its settings,
validated), :class:`AdaptTarget` (the conditioning query to adapt, raw units), :class:`IterationLog`
and :class:`AdaptResult`.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import TYPE_CHECKING

import numpy as np

from ..validation import check_lr_final, check_positive_int

if TYPE_CHECKING:  # annotations only: the settings import no torch
    from ..model.cnmp import CNMP, Query

MODES = ("acnmp", "rl_only", "lfd_only")
ADVANTAGES = ("awr", "reinforce")
#: Which executed roll-out can be adapt()'s solution (``AdaptConfig.solution``).
SOLUTIONS = ("mean", "any")
#: Shapes of the exploration noise (``AdaptConfig.noise``).
NOISES = ("rbf", "cubic", "demos")


@dataclass
class AdaptConfig:
    """Hyper-parameters of adaptation. The defaults are the product's, the same for every task;
    :meth:`paper` gives the paper's method as the six experiments report it (:data:`PAPER`).

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
    noise : "rbf" (the default: :class:`~acnmp_core.adaptation.exploration.SmoothNoise`, ``n_knots`` knots, the
        std the same at every step) or "cubic" (the authors' E4 noise,
        :class:`~acnmp_core.adaptation.exploration.CubicNoise`: the least-squares cubic through ``n_knots``
        >= 4 samples of the std, about 0.42 x it per step on average) or "demos" (a random
        combination of the demonstrations' deviations from their mean,
        :class:`~acnmp_core.adaptation.exploration.DemoNoise`, its root mean square the std: the outputs move
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
    mean_first : True (the default): every iteration executes its mean alone first and its noisy
        roll-outs only if the mean failed, so a mean that succeeds costs one roll-out; False (the
        paper's method): only the first iteration does, the others execute the mean and the noisy
        roll-outs as one batch (one round trip to the workers), and all of them count.
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
    mean_first: bool = True

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
        for name in ("stop_on_success", "mean_first"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name}: expected true or false, got {getattr(self, name)!r}")
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
    def paper(cls, **overrides) -> "AdaptConfig":
        """The paper's method as this project reproduces it (the six experiments report it):
        :data:`PAPER` over the defaults, then ``overrides``."""
        return cls(**{**PAPER, **overrides})

    @classmethod
    def from_dict(cls, d: dict) -> "AdaptConfig":
        """Build from a dict of field values (unknown keys are an error naming them)."""
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"config: unknown AdaptConfig field(s) {', '.join(unknown)}")
        return cls(**d)


#: The fields in which the paper's method (:meth:`AdaptConfig.paper`) differs from the defaults: its
#: iterations execute the mean and the noisy roll-outs as one batch.
PAPER: dict = {"mean_first": False}


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


@dataclass
class AssimilationConfig:
    """Continued training after a solution joins the demonstrations.

    steps : supervised steps (0 adds the demonstration without training).
    lr : Adam learning rate (below the first training's, see the module docstring).
    batch_size : random episodes per step (from all demonstrations, the solution included).
    n_targets : target points per episode.
    anchor_weight : weight of the anchor NLL (the solution given the adaptation's conditions).
    lr_final : None keeps ``lr`` constant; a number decays it along a half cosine to ``lr_final``
        at the last step (:func:`~acnmp_core.model.training.cosine_lr`).
    targets_include_obs : the episodes' observations are among their targets (see
        :class:`~acnmp_core.model.episodes.EpisodeSampler`); False: never (the authors').
    """

    steps: int = 1000
    lr: float = 1e-4
    batch_size: int = 32
    n_targets: int = 10
    anchor_weight: float = 1.0
    lr_final: float | None = None
    targets_include_obs: bool = False

    def __post_init__(self) -> None:
        check_positive_int("steps", self.steps, minimum=0)
        check_positive_int("batch_size", self.batch_size)
        check_positive_int("n_targets", self.n_targets)
        if isinstance(self.lr, bool) or not isinstance(self.lr, (int, float)) or not self.lr > 0:
            raise ValueError(f"lr: expected a number > 0, got {self.lr!r}")
        check_lr_final(self.lr, self.lr_final)
        if isinstance(self.anchor_weight, bool) or not isinstance(self.anchor_weight, (int, float)) \
                or not self.anchor_weight >= 0:
            raise ValueError(f"anchor_weight: expected a number >= 0, got {self.anchor_weight!r}")
