"""What the peers comparison runs (:class:`PeersConfig`) and what one run gives (:class:`PeerRun`)."""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ...errors import InputError

#: the methods that execute whole trajectories: LfD only (the product's model, the paper's CNMP and
#: the previous default's), ACNMP (the product's default, the paper's method and the previous
#: default: the linear path beside the network always), ProMP + RL, ProMP + CMA-ES (the
#: basis count chosen on the demonstrations, and fancy_gym's 5), and the ProMP methods on the dense
#: reward where a task gives them another one by default (E2: :data:`DENSE_METHODS`)
TRAJECTORY_METHODS = ("lfd", "lfd_paper", "lfd_linear", "acnmp", "acnmp_paper", "acnmp_linear", "promp_rl",
                      "promp_cma", "promp_cma5", "promp_rl_dense", "promp_cma_dense", "promp_cma5_dense")
#: the ProMP methods given the reward ACNMP adapts on where their own differs (E2's final distance
#: against its time-averaged distance): the same information for every method
DENSE_METHODS = ("promp_rl_dense", "promp_cma_dense", "promp_cma5_dense")
#: the step-based methods (stable-baselines3), warm-started by behaviour cloning or from scratch
STEP_BASED_METHODS = ("ppo_bc", "ppo", "sac_bc", "sac")
METHODS = TRAJECTORY_METHODS + STEP_BASED_METHODS
#: ACNMP's own methods and LfD only: the rest are its peers
OWN_METHODS = ("lfd", "lfd_paper", "lfd_linear", "acnmp", "acnmp_paper", "acnmp_linear")
CASES = ("extrapolation", "interpolation")
#: the episode budget of every adaptive method per test position (LfD only executes one)
BUDGET = 1000
#: CNMP training steps (the project's default)
TRAIN_STEPS = 3000
#: the names of E1's, E2's, E3's and the Pusher's tasks (their classes: :mod:`.tasks`)
E1_TASK, E2_TASK, E3_TASK, PUSHER_TASK = "e1-viapoint", "e2-push", "e3-wall", "pusher"
#: the path families whose demonstrations bend with their condition (:mod:`acnmp_core.tasks.families`)
FAMILY_TASKS = ("bump", "arc")
#: the tasks whose demonstrations are not linear in their conditions (the linear path's held-out
#: error on them: benchmarks/studies/method/README.md)
NON_LINEAR_TASKS = (E2_TASK, E3_TASK) + FAMILY_TASKS
#: the seeds every choice of a method, its settings and its peers' settings is made on
DEVELOPMENT_SEEDS = (0, 1, 2, 3, 4)
#: the seeds the comparison of record reports: no study, test or tuning runs them
REPORT_SEEDS = tuple(range(5, 15))


def check_development_seeds(seeds, what: str) -> tuple[int, ...]:
    """``seeds`` as a tuple if none is a report seed (:data:`REPORT_SEEDS`), else InputError naming
    ``what`` (a study, a setting) and the report seeds it names: they belong to the run of record."""
    seeds = tuple(int(s) for s in seeds)
    bad = sorted(set(seeds) & set(REPORT_SEEDS))
    if bad:
        raise InputError(f"{what}: seeds {', '.join(map(str, bad))} are report seeds, run by the comparison of "
                         f"record alone; choose on the development seeds {DEVELOPMENT_SEEDS[0]}-{DEVELOPMENT_SEEDS[-1]}")
    return seeds


def _task_names() -> tuple[str, ...]:
    from ...tasks.metaworld.scene import TASKS

    return tuple(TASKS) + (E1_TASK, E2_TASK, E3_TASK, PUSHER_TASK) + FAMILY_TASKS


#: every task's name, in the order of the results: Meta-World's, then E1, E2, E3, the Pusher and
#: the path families
TASK_NAMES = _task_names()
#: the libraries whose versions the result records
LIBRARIES = ("metaworld", "mujoco", "gymnasium", "pybullet", "stable-baselines3", "mp-pytorch", "cma", "torch",
             "numpy")


@dataclass(frozen=True)
class PeersConfig:
    """What :func:`~acnmp_core.experiments.peers.run.run_peers` runs.

    tasks : among :data:`TASK_NAMES`. methods : among
    :data:`METHODS`. seeds : one CNMP (per model kind) and one test position per case each (default:
    the development seeds; the comparison of record runs :data:`REPORT_SEEDS`). cases :
    among :data:`CASES` (a task runs those that apply to it). train_steps : CNMP training. budget :
    episodes per test position of every adaptive method. eval_every : SB3 training episodes between
    two evaluations of the deterministic policy. bc_steps : behaviour cloning's Adam steps.
    """

    tasks: tuple[str, ...]
    methods: tuple[str, ...] = TRAJECTORY_METHODS
    seeds: tuple[int, ...] = DEVELOPMENT_SEEDS
    cases: tuple[str, ...] = CASES
    train_steps: int = TRAIN_STEPS
    budget: int = BUDGET
    eval_every: int = 10
    bc_steps: int = 3000

    def __post_init__(self) -> None:
        for name, given, known in (("tasks", self.tasks, TASK_NAMES), ("methods", self.methods, METHODS),
                                   ("cases", self.cases, CASES)):
            bad = [g for g in given if g not in known]
            if not given or bad:
                raise InputError(f"{name}: expected some of {', '.join(known)}, got {', '.join(map(str, bad)) or 'none'}")
        if not self.seeds or any(int(s) < 0 for s in self.seeds):
            raise InputError(f"seeds: expected at least one seed >= 0, got {list(self.seeds)}")
        for name in ("train_steps", "budget", "eval_every", "bc_steps"):
            if int(getattr(self, name)) < 1:
                raise InputError(f"{name}: expected at least 1, got {getattr(self, name)}")

    def budget_of(self, method: str) -> int:
        """The episode budget of ``method``: one for LfD only, :attr:`budget` for the others."""
        return 1 if method.startswith("lfd") else int(self.budget)


@dataclass
class PeerRun:
    """One method at one test position.

    episodes : executed until its deterministic output first succeeded, or all it executed
    (censored). budget : its episode budget. censored : it did not succeed within the budget.
    time_s : wall time of the run (s; the CNMP methods' without the CNMP's training, ``train_s``).
    details : method-specific numbers (errors in the task's units, curves [[episodes, error], ...]).
    """

    task: str
    method: str
    seed: int
    case: str
    params: list[float]
    episodes: int
    success: bool
    budget: int
    time_s: float
    details: dict = field(default_factory=dict)
    wall_s: float | None = None
    commit: str | None = None

    @property
    def whole_wall_s(self) -> float:
        """:attr:`wall_s`, or for a run that did not record it its time and its model's training."""
        if self.wall_s is not None:
            return float(self.wall_s)
        return float(self.time_s) + float(self.details.get("train_s") or 0.0)

    @property
    def censored(self) -> bool:
        return not self.success

    @property
    def shown(self) -> str:
        """The episodes as the page shows them: a number, or "> budget" when censored."""
        return str(self.episodes) if self.success else f"> {self.budget}"

    def to_json(self) -> dict:
        return {**asdict(self), "censored": self.censored, "shown": self.shown}

    @classmethod
    def from_json(cls, d: dict) -> "PeerRun":
        return cls(**{k: d[k] for k in ("task", "method", "seed", "case", "params", "episodes", "success",
                                        "budget", "time_s")}, details=d.get("details", {}), wall_s=d.get("wall_s"),
                   commit=d.get("commit"))

    @property
    def key(self) -> tuple:
        return (self.task, self.method, self.seed, self.case)


def mean_episodes(runs: list[PeerRun]) -> tuple[float, bool]:
    """The mean episodes of ``runs`` and whether it is a lower bound: a censored run counts the
    episodes it executed (its budget), which its first success would exceed."""
    return float(np.mean([r.episodes for r in runs])), any(r.censored for r in runs)


def median_episodes(runs: list[PeerRun]) -> float:
    """The median episodes of ``runs``, a censored run counting as beyond every number (inf when
    half of them or more are censored)."""
    return float(np.median([r.episodes if r.success else np.inf for r in runs]))


def library_versions() -> dict[str, str | None]:
    """The installed version of every library of :data:`LIBRARIES` (None when missing)."""
    from importlib.metadata import PackageNotFoundError, version

    out: dict[str, str | None] = {}
    for name in LIBRARIES:
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = None
    return out
