"""ACNMP against the peers a robot-learning user would pick instead, on Meta-World (``acnmp experiment peers``).

Tasks: Meta-World's ``reach-v3``, ``push-v3`` and ``pick-place-v3`` as the robot kinds
``metaworld-*`` (:mod:`acnmp_core.tasks.metaworld`). Per task and seed, one test position outside
the demonstrations' region (*extrapolation*) and one inside (*interpolation*), drawn with the seed
(:func:`test_position`). Methods, all on the same demonstrations (Meta-World's scripted policies at
positions of the training region, the failed ones dropped) and the same test positions:

* ``lfd``: the CNMP trained on the demonstrations, conditioned on the test position, executed once;
* ``acnmp``: from that model, :func:`~acnmp_core.adaptation.loop.adapt` (RL with simultaneous SL) with
  the project's defaults until its mean trajectory succeeds;
* ``promp_rl``: the project's adaptive ProMP + episodic REPS (:mod:`acnmp_core.baselines.promp_rl`, E2's settings);
* ``promp_cma``: black-box ProMP + CMA-ES, fancy_gym's recipe with ``mp_pytorch`` and ``cma``,
  started from the demonstrations' ProMP conditioned on the test position
  (:mod:`acnmp_core.peers.black_box`);
* ``ppo``, ``sac``: stable-baselines3 from scratch on the step-based environment;
* ``ppo_bc``, ``sac_bc``: the same, their policy first fitted to the demonstrations' (observation,
  action) pairs by behaviour cloning (:mod:`acnmp_core.peers.step_based`).

One metric for all: **episodes executed until the method's deterministic output first succeeds**
(its mean trajectory, the distribution's mean, the deterministic policy; the episodes that
evaluated it count), with Meta-World's success. A method that does not succeed within its budget is
*censored*: reported as "> budget", never as a number it did not reach. Budgets
(:class:`PeersConfig`): LfD one episode; ACNMP :data:`ACNMP_BUDGET`; ProMP + RL and ProMP + CMA-ES
:data:`PROMP_BUDGET`; the stable-baselines3 methods ``sb3_factor`` (20) times ACNMP's median at
that task and case (a censored ACNMP run counting as its budget), at least ``sb3_min_budget``.

The study of what the linear peers exploit: for every lfd and promp_cma run, the run records the
distance (m, root mean square over the steps, hand x, y, z) between the trajectory the method
starts from (the CNMP's mean; the conditioned ProMP's mean, a linear regression of the
demonstrations' weights on their task parameters) and the scripted expert's own hand path at the
test position (``path_error_to_expert``).

The result is written after every run (:func:`run_peers` with ``out``), so a partial run is usable
and ``resume`` continues it.
"""
from __future__ import annotations

import copy
import json
import os
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..adaptation.config import AdaptConfig
from ..errors import InputError
from ..baselines.promp_rl import PrompRLConfig

TRAJECTORY_METHODS = ("lfd", "acnmp", "promp_rl", "promp_cma")
STEP_BASED_METHODS = ("ppo", "ppo_bc", "sac_bc", "sac")
METHODS = TRAJECTORY_METHODS + STEP_BASED_METHODS
CASES = ("extrapolation", "interpolation")
#: ACNMP's episode budget per test position (the Pusher example's)
ACNMP_BUDGET = 400
#: ProMP + RL's and ProMP + CMA-ES's episode budget per test position (E2's)
PROMP_BUDGET = 1500
#: CNMP training steps (the project's default)
TRAIN_STEPS = 3000
#: the libraries whose versions the result records
LIBRARIES = ("metaworld", "mujoco", "gymnasium", "stable-baselines3", "mp-pytorch", "cma", "torch", "numpy")


@dataclass(frozen=True)
class PeersConfig:
    """What :func:`run_peers` runs.

    tasks : robot kinds (``metaworld-reach`` ...). methods : among :data:`METHODS`. seeds : one CNMP
    and one test position per case each. cases : among :data:`CASES`. train_steps : CNMP training.
    acnmp_budget, promp_budget, cma_budget : episodes per test position. sb3_factor, sb3_min_budget :
    the stable-baselines3 budget, ``max(sb3_factor x ACNMP's median, sb3_min_budget)``; sb3_budget :
    a fixed budget instead (no ACNMP run needed). eval_every : SB3 training episodes between two
    evaluations of the deterministic policy. bc_steps : behaviour cloning's Adam steps.
    """

    tasks: tuple[str, ...]
    methods: tuple[str, ...] = TRAJECTORY_METHODS
    seeds: tuple[int, ...] = (0, 1, 2, 3, 4)
    cases: tuple[str, ...] = CASES
    train_steps: int = TRAIN_STEPS
    acnmp_budget: int = ACNMP_BUDGET
    promp_budget: int = PROMP_BUDGET
    cma_budget: int = PROMP_BUDGET
    sb3_factor: float = 20.0
    sb3_min_budget: int = 200
    sb3_budget: int | None = None
    eval_every: int = 10
    bc_steps: int = 3000

    def __post_init__(self) -> None:
        from ..tasks.metaworld.scene import TASKS

        for name, given, known in (("tasks", self.tasks, tuple(TASKS)), ("methods", self.methods, METHODS),
                                   ("cases", self.cases, CASES)):
            bad = [g for g in given if g not in known]
            if not given or bad:
                raise InputError(f"{name}: expected some of {', '.join(known)}, got {', '.join(map(str, bad)) or 'none'}")
        if not self.seeds or any(int(s) < 0 for s in self.seeds):
            raise InputError(f"seeds: expected at least one seed >= 0, got {list(self.seeds)}")
        for name in ("train_steps", "acnmp_budget", "promp_budget", "cma_budget", "sb3_min_budget", "eval_every"):
            if int(getattr(self, name)) < 1:
                raise InputError(f"{name}: expected at least 1, got {getattr(self, name)}")
        if self.sb3_budget is not None and self.sb3_budget < 1:
            raise InputError(f"sb3_budget: expected at least 1, got {self.sb3_budget}")


@dataclass
class PeerRun:
    """One method at one test position.

    episodes : executed until its deterministic output first succeeded, or all it executed
    (censored). budget : its episode budget. censored : it did not succeed within the budget.
    time_s : wall time of the run (s; ACNMP's and LfD's without the CNMP's training, ``train_s``).
    details : method-specific numbers (errors m, curves [[episodes, error m], ...]).
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
                                        "budget", "time_s")}, details=d.get("details", {}))

    @property
    def key(self) -> tuple:
        return (self.task, self.method, self.seed, self.case)


def test_position(kind: str, case: str, seed: int) -> np.ndarray:
    """(P,) m: seed ``seed``'s test position of ``case`` on task ``kind``, drawn from the region
    (:meth:`~acnmp_core.tasks.metaworld.scene.MetaWorldTask.sample_extrapolation` or
    ``sample_training``) with generator ``[seed, case index]`` until Meta-World's scripted expert
    succeeds there."""
    from ..tasks.metaworld.demos import expert_succeeds
    from ..tasks.metaworld.scene import task

    spec = task(kind)
    rng = np.random.default_rng([int(seed), CASES.index(case)])
    while True:
        p = spec.sample_extrapolation(rng) if case == "extrapolation" else spec.sample_training(rng)
        if expert_succeeds(kind, p):
            return p


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


def sb3_budget(config: PeersConfig, runs: list[PeerRun], task: str, case: str) -> int:
    """The stable-baselines3 budget at ``task`` and ``case``: ``config.sb3_budget`` when set, else
    ``max(sb3_factor x ACNMP's median episodes there (a censored run counting as its budget),
    sb3_min_budget)``; InputError when no ACNMP run there is recorded."""
    if config.sb3_budget is not None:
        return int(config.sb3_budget)
    acnmp = [r.episodes if r.success else r.budget for r in runs if (r.task, r.method, r.case) == (task, "acnmp", case)]
    if not acnmp:
        raise InputError(f"methods: the stable-baselines3 budget at {task} {case} is {config.sb3_factor:g} x ACNMP's "
                         f"median there, and no ACNMP run is recorded: run acnmp first (same --out) or give --sb3-budget")
    return int(max(round(config.sb3_factor * float(np.median(acnmp))), config.sb3_min_budget))


def _path_error(trajectory: np.ndarray, expert: np.ndarray) -> float:
    """Root mean square over steps of the hand's distance (m) between two (T, 4) trajectories."""
    return float(np.sqrt(np.mean(np.sum((np.asarray(trajectory)[:, :3] - expert[:, :3]) ** 2, axis=1))))


class _Task:
    """One task's shared material: demonstrations, evaluator, test positions, expert paths."""

    def __init__(self, kind: str):
        from ..robots.registry import robot
        from ..tasks.metaworld.demos import expert_transitions, metaworld_demos
        from ..robots.metaworld import task_name
        from ..tasks.metaworld.scene import task

        self.kind, self.spec = kind, task(kind)
        self.arrays = metaworld_demos(kind)
        self.transitions = expert_transitions(kind)
        self.evaluator = robot(kind).make_evaluator(task_name(kind))
        self._positions: dict[tuple[int, str], np.ndarray] = {}
        self._experts: dict[tuple[int, str], np.ndarray] = {}

    def position(self, seed: int, case: str) -> np.ndarray:
        if (seed, case) not in self._positions:
            self._positions[seed, case] = test_position(self.kind, case, seed)
        return self._positions[seed, case]

    def expert_path(self, seed: int, case: str) -> np.ndarray:
        from ..tasks.metaworld.demos import expert_episode

        if (seed, case) not in self._experts:
            self._experts[seed, case] = expert_episode(self.kind, self.position(seed, case)).trajectory
        return self._experts[seed, case]

    def setup(self, seed: int):
        from .push import PushSetup

        a = self.arrays
        return PushSetup(demos=a.to_demo_set(), targets={c: self.position(seed, c) for c in CASES},
                         times=a.times[0].copy(), q0=a.values[:, 0].mean(axis=0), n_joints=a.values.shape[2],
                         tolerance=self.spec.radius, demo_arrays=a)

    def close(self) -> None:
        self.evaluator.close()


def _train(task: _Task, seed: int, steps: int):
    from ..model.cnmp import CNMP, CNMPConfig
    from ..model.training import TrainConfig, train

    a = task.arrays
    model = CNMP(CNMPConfig(n_outputs=a.values.shape[2], n_task_params=a.task_params.shape[1],
                            output_names=[str(n) for n in a.value_names],
                            task_param_names=[str(n) for n in a.task_param_names]), seed=seed)
    train(model, a.to_demo_set(), TrainConfig(steps=steps), seed=seed)
    return model


def _trajectory_runs(task: _Task, config: PeersConfig, seed: int, case: str, todo: set[str], state: dict,
                     emit: Callable[[PeerRun], None]) -> None:
    """The trajectory methods of ``todo`` at ``seed``'s ``case`` position, each given to ``emit`` as
    it finishes; ``state`` keeps the seed's CNMP (trained once for both cases)."""
    from ..peers.black_box import BlackBoxConfig, DemoProMP, run_black_box
    from .push import make_target, run_acnmp_case, run_promp_case

    p = task.position(seed, case)
    setup = task.setup(seed)
    expert = task.expert_path(seed, case)
    if {"lfd", "acnmp"} & todo:
        if state.get("model_seed") != seed:
            t0 = time.perf_counter()
            state["model"], state["model_seed"] = _train(task, seed, config.train_steps), seed
            state["train_s"] = round(time.perf_counter() - t0, 2)
        model = state["model"]
        lfd_traj = model.predict_query(make_target(setup, case).query(model)).mean
        path = _path_error(lfd_traj, expert)
        # ACNMP's first episode is the LfD trajectory: LfD only is that episode alone
        for method, budget in (("lfd", 1), ("acnmp", config.acnmp_budget)):
            if method not in todo:
                continue
            t0 = time.perf_counter()
            r = run_acnmp_case(copy.deepcopy(model), setup, case, task.evaluator, AdaptConfig(max_rollouts=budget), seed)
            details = {"final_error": r["final_error"], "lfd_error": r["lfd_error"], "train_s": state["train_s"],
                       "curve": r["curve"]}
            if method == "lfd":
                details["path_error_to_expert"] = path
            emit(PeerRun(task.kind, method, seed, case, p.tolist(), int(r["rollouts"]), bool(r["success"]),
                               budget, round(time.perf_counter() - t0, 2), details))
    if "promp_rl" in todo:
        t0 = time.perf_counter()
        from .push import PROMP_DEFAULTS

        cfg = PrompRLConfig(**{**PROMP_DEFAULTS, "max_rollouts": config.promp_budget, "seed": seed})
        r = run_promp_case(setup, case, task.evaluator, cfg)
        emit(PeerRun(task.kind, "promp_rl", seed, case, p.tolist(), int(r["rollouts"]), bool(r["success"]),
                           config.promp_budget, round(time.perf_counter() - t0, 2),
                           {"final_error": r["final_error"], "lfd_error": r["lfd_error"], "curve": r["curve"]}))
    if "promp_cma" in todo:
        t0 = time.perf_counter()
        a = task.arrays
        promp = DemoProMP(a.times[0], a.values, a.task_params)
        r = run_black_box(promp, task.evaluator, p, BlackBoxConfig(budget=config.cma_budget), seed)
        start = promp.trajectories(promp.conditioned_mean(p)[None])[0]
        emit(PeerRun(task.kind, "promp_cma", seed, case, p.tolist(), r.episodes, r.success, config.cma_budget,
                           round(time.perf_counter() - t0, 2),
                           {"final_error": r.curve[-1][1], "lfd_error": r.curve[0][1], "curve": r.curve,
                            "sigma0": r.sigma0, "dimension": r.dimension,
                            "path_error_to_expert": _path_error(start, expert)}))


def _step_based_run(task: _Task, config: PeersConfig, seed: int, case: str, method: str, budget: int) -> PeerRun:
    from ..peers.step_based import StepBasedConfig, run_step_based

    p = task.position(seed, case)
    algorithm, _, warm = method.partition("_")
    cfg = StepBasedConfig(algorithm, budget, eval_every=config.eval_every, warm_start=warm or None,
                          bc_steps=config.bc_steps)
    t0 = time.perf_counter()
    r = run_step_based(task.kind, p, cfg, seed, task.transitions if warm else None)
    return PeerRun(task.kind, method, seed, case, p.tolist(), r.episodes, r.success, budget,
                   round(time.perf_counter() - t0, 2),
                   {"final_error": r.curve[-1][1] if r.curve else None, "lfd_error": r.curve[0][1] if r.curve else None,
                    "curve": r.curve, "train_episodes": r.train_episodes, "eval_episodes": r.eval_episodes,
                    "bc_loss": r.bc_loss})


def plan(config: PeersConfig) -> list[tuple[str, int, str, str]]:
    """(task, seed, case, method) in the order :func:`run_peers` runs them: every trajectory method
    first (task by task, seed by seed, both cases), then the stable-baselines3 methods (method by
    method in :data:`STEP_BASED_METHODS` order, then task, case and seed), so that each SB3 budget
    can be set from ACNMP's runs."""
    traj = [(t, s, c, m) for t in config.tasks for s in config.seeds for c in config.cases
            for m in TRAJECTORY_METHODS if m in config.methods]
    steps = [(t, s, c, m) for m in STEP_BASED_METHODS if m in config.methods for t in config.tasks
             for c in config.cases for s in config.seeds]
    return traj + steps


def summarise(runs: list[PeerRun]) -> dict:
    """Per task, case and method: ``runs``, ``successes``, ``median_episodes`` (None when half of the
    runs or more are censored: the median is then beyond the budget, ``median_shown`` "> budget"),
    ``median_time_s``, ``budget`` (the largest)."""
    out: dict = {}
    for r in runs:
        out.setdefault(r.task, {}).setdefault(r.case, {}).setdefault(r.method, []).append(r)
    summary: dict = {}
    for task, cases in out.items():
        for case, methods in cases.items():
            for method, rs in methods.items():
                eps = sorted(r.episodes if r.success else np.inf for r in rs)
                median = float(np.median(eps))
                budget = max(r.budget for r in rs)
                summary.setdefault(task, {}).setdefault(case, {})[method] = {
                    "runs": len(rs), "successes": int(sum(r.success for r in rs)),
                    "median_episodes": None if not np.isfinite(median) else median,
                    "median_shown": f"> {budget}" if not np.isfinite(median) else f"{median:g}",
                    "median_time_s": float(np.median([r.time_s for r in rs])), "budget": budget,
                    "seeds": [r.seed for r in rs]}
    return summary


def load_runs(path: str | Path) -> list[PeerRun]:
    """The runs of a result JSON written by :func:`run_peers` (none when the file does not exist)."""
    path = Path(path)
    if not path.exists():
        return []
    try:
        data = json.loads(path.read_text())
        return [PeerRun.from_json(r) for r in data["runs"]]
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(f"{path}: not a peers result to resume ({exc})") from None


def _write(path: Path, result: dict) -> None:
    """Write ``result`` to ``path`` atomically (a reader never sees half a file)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(result, indent=1) + "\n")
    os.replace(tmp, path)


def run_peers(config: PeersConfig, *, out: str | Path | None = None, resume: bool = False,
              header: dict | None = None, on_run: Callable[[PeerRun], None] | None = None,
              progress: bool = False, budgets_from: str | Path | None = None) -> dict:
    """Run :func:`plan`'s runs and return the JSON-ready result: ``experiment`` "peers", ``config``,
    ``versions`` (:func:`library_versions`), ``regions`` (per task: training region and the
    extrapolation rule), ``runs`` (:class:`PeerRun` as JSON, with ``censored`` and ``shown``),
    ``summary`` (:func:`summarise`), ``not_run`` (the planned runs missing), ``wall_time_s``.

    out : the result is written there after every run (and at the end). resume : runs already in
    ``out`` (same task, method, seed, case) are kept and not run again. header : entries put first
    (e.g. provenance). on_run : called with each finished run. budgets_from : a result JSON whose
    ACNMP runs also set the stable-baselines3 budgets (read again before each SB3 run: another
    process may be writing it).
    """
    from ..tasks.metaworld.scene import EXTRAPOLATION_X, TASKS

    path = None if out is None else Path(out)
    runs = load_runs(path) if (resume and path is not None) else []
    done = {r.key for r in runs}
    todo = [item for item in plan(config) if (item[0], item[3], item[1], item[2]) not in done]
    t_start = time.perf_counter()
    before = sum(float(r.time_s) for r in runs)

    def result() -> dict:
        missing = [dict(zip(("task", "seed", "case", "method"), item)) for item in plan(config)
                   if (item[0], item[3], item[1], item[2]) not in {r.key for r in runs}]
        return {**(header or {}), "experiment": "peers", "config": _config_json(config),
                "versions": library_versions(),
                "regions": {k: {"params": list(TASKS[k].param_names), "training": [list(x) for x in TASKS[k].training],
                                "extrapolation_goal_abs_x": list(EXTRAPOLATION_X), "success_radius": TASKS[k].radius}
                            for k in config.tasks},
                "wall_time_s": round(before + time.perf_counter() - t_start, 1),
                "runs": [r.to_json() for r in runs], "summary": summarise(runs), "not_run": missing}

    if config.sb3_budget is None and "acnmp" not in config.methods:
        known = runs + (load_runs(budgets_from) if budgets_from is not None else [])
        for kind, seed, case, method in todo:  # refused before anything runs, not after an hour
            if method in STEP_BASED_METHODS:
                sb3_budget(config, known, kind, case)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc="peers", unit="run")
    tasks: dict[str, _Task] = {}
    state: dict = {}

    def emit(r: PeerRun) -> None:
        runs.append(r)
        if path is not None:
            _write(path, result())
        if bar is not None:
            bar.update(1)
        if on_run:
            on_run(r)

    try:
        i = 0
        while i < len(todo):
            kind, seed, case, method = todo[i]
            if kind not in tasks:
                tasks[kind] = _Task(kind)
            if method in TRAJECTORY_METHODS:
                # the trajectory methods of one (task, seed, case) run together (they share the CNMP)
                group = [item for item in todo[i:] if item[:3] == (kind, seed, case) and item[3] in TRAJECTORY_METHODS]
                _trajectory_runs(tasks[kind], config, seed, case, {g[3] for g in group}, state, emit)
                i += len(group)
            else:
                known = runs + (load_runs(budgets_from) if budgets_from is not None else [])
                emit(_step_based_run(tasks[kind], config, seed, case, method, sb3_budget(config, known, kind, case)))
                i += 1
    finally:
        if bar is not None:
            bar.close()
        for t in tasks.values():
            t.close()
    final = result()
    if path is not None:
        _write(path, final)
    return final


def _config_json(config: PeersConfig) -> dict:
    from .push import PROMP_DEFAULTS

    d = asdict(config)
    d.update(tasks=list(config.tasks), methods=list(config.methods), seeds=list(config.seeds), cases=list(config.cases))
    d["acnmp"] = {k: v for k, v in vars(AdaptConfig(max_rollouts=config.acnmp_budget)).items()
                  if isinstance(v, (int, float, str, bool, type(None)))}
    d["promp_rl"] = {**PROMP_DEFAULTS, "max_rollouts": config.promp_budget}
    from ..peers.black_box import N_BASIS
    from ..tasks.metaworld.demos import DEMO_SEED, N_DEMOS

    d["promp_cma"] = {"n_basis": N_BASIS, "budget": config.cma_budget, "popsize": "cma default (4 + 3 ln n)"}
    d["demonstrations"] = {"drawn": N_DEMOS, "seed": DEMO_SEED}
    return d


def run_line(r: PeerRun) -> str:
    """One line per finished run, for the command's log."""
    err = r.details.get("final_error")
    return (f"{r.task:<21} seed {r.seed} {r.case:<13} {r.method:<9} episodes {r.shown:>7} "
            f"success {str(r.success):<5} error {'-' if err is None else f'{err:.3f} m'} {r.time_s:.1f} s")


#: colours and labels of the methods in the figure
STYLE = {"lfd": ("tab:red", "LfD only"), "acnmp": ("tab:green", "ACNMP"), "promp_rl": ("tab:blue", "ProMP + RL"),
         "promp_cma": ("tab:purple", "ProMP + CMA-ES"), "ppo": ("tab:orange", "PPO"), "ppo_bc": ("tab:brown", "PPO + BC"),
         "sac_bc": ("tab:olive", "SAC + BC"), "sac": ("tab:gray", "SAC")}


def plot_peers(result: dict, path) -> Path:
    """Write the figure: per task (columns) and case (rows), the fraction of seeds whose method has
    succeeded against the episodes executed (log scale), one step line per method; censored runs
    never rise. Returns the path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    runs = [PeerRun.from_json(r) for r in result["runs"]]
    tasks = [t for t in result["config"]["tasks"] if any(r.task == t for r in runs)] or result["config"]["tasks"]
    cases = [c for c in result["config"]["cases"] if any(r.case == c for r in runs)] or result["config"]["cases"]
    fig, axes = plt.subplots(len(cases), len(tasks), figsize=(4.2 * len(tasks), 3.3 * len(cases)), squeeze=False)
    top = max([r.budget for r in runs] + [10])
    for row, case in enumerate(cases):
        for col, task in enumerate(tasks):
            ax = axes[row][col]
            for method in result["config"]["methods"]:
                rs = [r for r in runs if (r.task, r.case, r.method) == (task, case, method)]
                if not rs:
                    continue
                color, label = STYLE[method]
                done = sorted(r.episodes for r in rs if r.success)
                xs = [1.0] + [float(e) for e in done] + [float(top)]
                # methods that coincide (all succeeding at once) are told apart by a small offset
                lift = 0.012 * (METHODS.index(method) - len(METHODS) / 2)
                ys = [lift] + [(i + 1) / len(rs) + lift for i in range(len(done))] + [len(done) / len(rs) + lift]
                ax.step(xs, ys, where="post", color=color, lw=1.6, label=label)
            ax.set_xscale("log")
            ax.set_ylim(-0.03, 1.03)
            ax.set_title(f"{task.removeprefix('metaworld-')}, {case}", fontsize=10)
            if col == 0:
                ax.set_ylabel("fraction of seeds succeeded")
            if row == len(cases) - 1:
                ax.set_xlabel("episodes executed (log)")
    handles = {}
    for ax in axes.flat:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lab, h)
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=min(4, len(handles)), fontsize=8)
    fig.suptitle("Meta-World: fraction of seeds succeeded against episodes executed", fontsize=10)
    fig.tight_layout(rect=(0, 0.04 + 0.03 * ((len(handles) + 3) // 4), 1, 0.96))
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def merge_results(results: list[dict], header: dict | None = None, planned: list[dict] | None = None) -> dict:
    """One result of several :func:`run_peers` results (e.g. the trajectory methods and the SB3
    ones, run by two processes): their runs (a (task, method, seed, case) twice: ValueError), the
    union of their tasks, methods, seeds and cases, the summary again, the summed wall time and
    each part's ``provenance`` and ``config`` under ``parts``. ``planned``: more plans ({tasks,
    methods, seeds, cases} lists each) whose runs missing from every part are listed under
    ``not_run`` with the parts' own missing runs."""
    runs: dict[tuple, PeerRun] = {}
    for res in results:
        for r in map(PeerRun.from_json, res["runs"]):
            if r.key in runs:
                raise ValueError(f"merge: {r.key} is in two results")
            runs[r.key] = r
    first = results[0]
    config = dict(first["config"])
    from ..tasks.metaworld.scene import TASKS

    for key, order in (("tasks", tuple(TASKS)), ("methods", METHODS), ("seeds", None), ("cases", CASES)):
        values = {v for res in results for v in res["config"][key]} | {getattr(r, key[:-1]) for r in runs.values()}
        config[key] = sorted(values, key=(order.index if order else None) or (lambda v: v))

    merged = sorted(runs.values(), key=lambda r: (config["tasks"].index(r.task), METHODS.index(r.method), r.case, r.seed))
    return {**(header or {}), "experiment": "peers", "config": config, "versions": first["versions"],
            "regions": {k: v for res in results for k, v in res["regions"].items()},
            "wall_time_s": round(sum(res["wall_time_s"] for res in results), 1),
            "runs": [r.to_json() for r in merged], "summary": summarise(merged),
            "not_run": (missing := _missing(results, planned or [], runs)),
            "parts": [{"provenance": res.get("provenance"), "config": res["config"], "wall_time_s": res["wall_time_s"]}
                      for res in results],
            "planned_runs": len(runs) + len(missing)}


def _missing(results: list[dict], planned: list[dict], runs: dict) -> list[dict]:
    """The runs the parts planned (their ``not_run``) or ``planned`` names that no part made, once each."""
    items = [(x["task"], x["seed"], x["case"], x["method"]) for res in results for x in res["not_run"]]
    items += [(t, s, c, m) for p in planned for t in p["tasks"] for s in p["seeds"] for c in p["cases"] for m in p["methods"]]
    out, seen = [], set()
    for task, seed, case, method in items:
        if (task, method, seed, case) in runs or (task, seed, case, method) in seen:
            continue
        seen.add((task, seed, case, method))
        out.append({"task": task, "seed": seed, "case": case, "method": method})
    return out
