"""E2: a 3-DoF planar arm pushes a cylinder to a target; ACNMP vs adaptive ProMP + RL (paper Sec. 4.2).

Per seed, both methods face two test targets of :func:`~acnmp_core.tasks.push.demos.push_targets`:
the held-out **interpolation** target (inside the 9 training targets' range) and the
**extrapolation** target (outside it).

* ACNMP: a CNMP trained on the 9 joint-space demonstrations (task parameters: target x, y) is
  conditioned on the test target and on the start configuration (an observation at t = 0); its
  mean trajectory is executed once (LfD). If it misses, :func:`~acnmp_core.adaptation.loop.adapt`
  (mode "acnmp": RL with simultaneous SL on the demos) runs until success or the budget.
* ProMP + RL: :func:`~acnmp_core.baselines.promp_rl.adapt_promp`, initialised from the nearest demonstrated
  skill (Stark et al. 2019), episodic REPS over the ProMP weights until success or the budget.

Both run through the same :class:`~acnmp_core.rollout.RolloutEvaluator` (by default one in-process
:class:`~acnmp_core.tasks.push.task.PlanarPushTask`; ``evaluator_factory`` plugs remote workers in).
Reward (:data:`REWARDS`): ACNMP gets minus the cylinder's distance (m) to the target at every step
(over T), credited to the actions before it; ProMP + RL, an episodic method, gets minus the final
distance, exactly the objective it was tuned on (with the dense reward its return would mix the
approach phase into the search and it needs ~3x more roll-outs). Success, for both: the final
distance is at most ``tolerance`` (0.03 m, the cylinder's radius).

The task setting (:mod:`~acnmp_core.tasks.push.settings`: "paper", the default, or "authors")
fixes the cylinder's start, the targets and ACNMP's reward ("tracking" in the authors' setting: the
squared distance to the cylinder's path in the held-out demonstration, :func:`reference_path`).

Everything here is plain library code; ``acnmp experiment push`` is a thin adapter around
:func:`run_push`, whose result is a JSON-ready dict.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..adaptation.loop import adapt
from ..adaptation.config import AdaptConfig, AdaptTarget
from ..baselines.promp_rl import PrompRLConfig, adapt_promp
from ..data.demo_io import DemoArrays
from ..data.demos import DemoSet
from ..model.cnmp import CNMP, CNMPConfig
from ..model.training import TrainConfig, train
from ..rollout import RolloutEvaluator
from ..tasks.push.settings import PAPER, PushSetting
from .recipe import PAPER as PAPER_METHOD, Protocol, Recipe, model_prior

METHODS = ("acnmp", "promp_rl")
CASES = ("interpolation", "extrapolation")
#: Success tolerance (m) on the cylinder's final distance to the target: one cylinder radius.
TOLERANCE = 0.03

#: ACNMP's roll-out budget per target (the adaptation settings are the library defaults).
ACNMP_BUDGET = 300
#: The push task's reward per method in the paper setting (PlanarPushTask ``reward``), see the
#: module docstring; :func:`reward_for` gives it for any setting and method.
REWARDS = {"acnmp": "distance", "promp_rl": "final"}
#: The ProMP + RL settings the baseline uses (Stark et al. 2019 style: nearest skill, REPS).
PROMP_DEFAULTS = dict(method="reps", n_samples=10, max_rollouts=1500)


@dataclass
class PushSetup:
    """Everything that defines an E2 run.

    demos : the 9 training demonstrations (times phase (300,), joint angles (300, 3) rad, target (2,) m).
    targets : {"interpolation": (2,), "extrapolation": (2,)} test targets (m).
    times : (300,) query times (phase in [0, 1]).
    q0 : (3,) start configuration (rad), shared by every demonstration.
    n_joints : arm DoF. tolerance : success tolerance (m).
    setting : the task setting (cylinder start, targets, ACNMP's reward).
    demo_arrays : all 11 demonstrations (training and the two held-out ones), for effects and
        reference paths.
    """

    demos: DemoSet
    targets: dict[str, np.ndarray]
    times: np.ndarray
    q0: np.ndarray
    n_joints: int = 3
    tolerance: float = TOLERANCE
    setting: PushSetting = PAPER
    demo_arrays: DemoArrays | None = None


def make_setup(demo_path: str | None = None, n_joints: int = 3, setting: PushSetting = PAPER) -> PushSetup:
    """Load (or generate and cache, ~2 s) the E2 demonstrations of ``setting`` and split them by role.

    ``demo_path`` : .npz in the project's demo format (default: the cache of
    :func:`~acnmp_core.tasks.push.demos.push_demos`).
    """
    from ..tasks.push.demos import push_demos

    arrays: DemoArrays = push_demos(n_joints, path=demo_path, setting=setting)
    train_arr = arrays.with_role("train")
    targets = {case: arrays.with_role(case).task_params[0].copy() for case in CASES}
    times = train_arr.times[0].copy()
    return PushSetup(demos=train_arr.to_demo_set(), targets=targets, times=times,
                     q0=train_arr.values[0, 0].copy(), n_joints=n_joints, setting=setting, demo_arrays=arrays)


def demo_effects(setup: PushSetup) -> np.ndarray:
    """(9, 2) m: each training demonstration's effect, the cylinder's final position when it is
    executed (Stark et al.'s effect description; prior experience, not counted as roll-outs)."""
    from ..tasks.push.demos import object_paths

    return object_paths(setup.demo_arrays.with_role("train").values, setup.setting)[:, -1]


def reference_path(setup: PushSetup, case: str) -> np.ndarray:
    """(T, 2) m: the cylinder's path in the expert's demonstration for ``case``'s target, the
    reference of the authors' tracking reward (the held-out demonstration, never trained on)."""
    from ..tasks.push.demos import object_paths

    return object_paths(setup.demo_arrays.with_role(case).values, setup.setting)[0]


def make_target(setup: PushSetup, case: str) -> AdaptTarget:
    """The CNMP conditioning for ``case``: target (x, y) as task parameters, q0 observed at t = 0."""
    return AdaptTarget(obs_times=setup.times[:1].copy(), obs_values=setup.q0[None].copy(),
                       task_params=setup.targets[case].copy(), query_times=setup.times.copy())


def adapt_settings(recipe: Recipe = PAPER_METHOD, budget: int = ACNMP_BUDGET) -> AdaptConfig:
    """ACNMP's adaptation settings in E2 under ``recipe`` (the paper's method: ``AdaptConfig.paper``;
    the default: ``AdaptConfig()``), with the protocol's ``budget`` roll-outs per target."""
    return recipe.adapt_config(Protocol(budget))


def train_push_cnmp(demos: DemoSet, seed: int, steps: int = 3000, progress: bool = False, prior: str = "none") -> CNMP:
    """The LfD model of E2: a default-size CNMP over joint angles with 2 task parameters; ``prior``
    its ``CNMPConfig.prior`` ("none": the paper's CNMP; "auto": chosen at training)."""
    model = CNMP(CNMPConfig(n_outputs=demos.n_outputs, n_task_params=demos.n_task_params,
                            output_names=[f"joint{i + 1}" for i in range(demos.n_outputs)],
                            task_param_names=["target_x", "target_y"], prior=prior), seed=seed)
    train(model, demos, TrainConfig(steps=steps), seed=seed, progress=progress)
    return model


def _final_error(evaluator: RolloutEvaluator, traj: np.ndarray, times: np.ndarray, target: np.ndarray) -> float:
    """Distance (m) of the cylinder's final position to ``target`` after executing ``traj`` (T, D)."""
    return float(evaluator.evaluate(traj[None], times, target).remaining_errors()[0])


def run_acnmp_case(model: CNMP, setup: PushSetup, case: str, evaluator: RolloutEvaluator,
                   cfg: AdaptConfig, seed: int, on_iteration: Callable | None = None) -> dict:
    """ACNMP on one test target: LfD roll-out, then adaptation if it missed.

    ``model`` is adapted in place (pass a copy). Returns ``{"rollouts", "success", "final_error",
    "lfd_error", "lfd_success", "adapted" (more than the LfD roll-out was executed), "curve":
    [[roll-outs, error of the mean], ...]}``.
    adapt()'s first roll-out is the mean, i.e. the LfD trajectory: when it succeeds the case costs
    one roll-out and no adaptation. Roll-outs count every executed trajectory.
    """
    return run_acnmp_target(model, setup.demos, make_target(setup, case), evaluator, cfg, seed, on_iteration)


def run_acnmp_target(model: CNMP, demos: DemoSet, target: AdaptTarget, evaluator: RolloutEvaluator,
                     cfg: AdaptConfig, seed: int, on_iteration: Callable | None = None) -> dict:
    """ACNMP (``cfg`` with mode "acnmp") on one conditioning ``target``: the model's first mean
    roll-out, then adaptation if it missed; the keys of :func:`run_acnmp_case`. ``model`` is adapted
    in place (pass a copy)."""
    res = adapt(model, demos, target, evaluator, replace(cfg, mode="acnmp"), seed=seed, on_iteration=on_iteration)
    out = {"lfd_error": res.history[0].mean_error, "lfd_success": bool(res.history[0].mean_success),
           "adapted": res.rollouts > 1,
           # the error of the mean roll-out against roll-outs used, as in the paper's Fig. 5(b)
           "curve": [[h.rollouts, h.mean_error] for h in res.history],
           "rollouts": res.rollouts, "success": bool(res.success),
           # what was executed within the budget: the last mean roll-out
           "final_error": res.history[-1].mean_error, "after_budget_error": None}
    if not res.success and res.rollouts > 1:
        # adapt() ends after an update it had no budget left to execute: that mean is measured once
        # here, not counted and not a success (it was never part of the run), and reported apart
        out["after_budget_error"] = _final_error(evaluator, res.trajectory, res.times, target.task_params)
    return out


def run_promp_case(setup: PushSetup, case: str, evaluator: RolloutEvaluator, cfg: PrompRLConfig,
                   n_basis: int = 20, effects: np.ndarray | None = None) -> dict:
    """Adaptive ProMP + RL on one test target. Returns the same keys as :func:`run_acnmp_case`
    (``lfd_*`` is the initial search distribution's mean trajectory). ``effects`` (9, 2) m: the
    demos' effects (:func:`demo_effects`), needed by the "similar" and "mixture" initialisations."""
    times = setup.times
    tv = np.stack([d.times for d in setup.demos])
    vals = np.stack([d.values for d in setup.demos])
    tps = np.stack([d.task_params for d in setup.demos])
    res = adapt_promp(tv, vals, tps, evaluator, times, setup.targets[case], cfg, n_basis=n_basis,
                      demo_effects=effects)
    errs = res.error_curve
    return {"rollouts": int(res.n_rollouts), "success": bool(res.success), "final_error": float(errs[-1]),
            "lfd_error": float(errs[0]), "lfd_success": bool(errs[0] <= setup.tolerance),
            "adapted": res.n_iterations > 0,
            "curve": [[int(r), float(e)] for r, e in zip(res.rollouts_at, errs)]}


def record_run(runs: list[dict], r: dict, seed: int, method: str, case: str, t_start: float,
               log: Callable[[str], None] | None, prefix: str = "", width: int = 8) -> None:
    """Append run ``r`` (a ``run_*_case`` result) to ``runs`` with its seed, method, case and time
    since ``t_start`` (perf_counter s), and log one line (``prefix`` first, method padded to ``width``)."""
    r = {"seed": seed, "method": method, "case": case, **r, "time_s": round(time.perf_counter() - t_start, 2)}
    runs.append(r)
    if log:
        after = r.get("after_budget_error")
        log(f"{prefix}seed {seed} {method:<{width}} {case:<13} roll-outs {r['rollouts']:>5} "
            f"success {str(r['success']):<5} error {r['final_error']:.4f} m "
            f"(initial {r['lfd_error']:.4f} m) {r['time_s']:.1f} s"
            + ("" if after is None else f"; the update after the budget, measured once and not counted: {after:.4f} m"))


def _summarise(runs: list[dict]) -> dict:
    """Median roll-outs / error and success rate over seeds of one (method, case)."""
    return {
        "rollouts_median": float(np.median([r["rollouts"] for r in runs])),
        "rollouts": [int(r["rollouts"]) for r in runs],
        "success_rate": float(np.mean([r["success"] for r in runs])),
        "final_error_median": float(np.median([r["final_error"] for r in runs])),
        "lfd_error_median": float(np.median([r["lfd_error"] for r in runs])),
        "lfd_success_rate": float(np.mean([r["lfd_success"] for r in runs])),
    }


def reward_for(setting: PushSetting, method: str) -> str:
    """PlanarPushTask reward of ``method`` in ``setting``: ACNMP's is the setting's, every ProMP
    method (episodic) gets the final distance."""
    return setting.acnmp_reward if method == "acnmp" else "final"


def task_config(setup: "PushSetup", method: str) -> dict:
    """The push task's parameters for ``method`` (see :data:`REWARDS`): ``{"n_joints", "tolerance",
    "reward"}``, as PlanarPushTask's keyword arguments and as a worker's task config (paper setting
    only: the workers' push task has the default cylinder start and no tracking reference)."""
    if setup.setting.name != PAPER.name:
        raise ValueError(f"setting: remote workers run the paper setting only, got {setup.setting.name!r}")
    return {"n_joints": setup.n_joints, "tolerance": setup.tolerance, "reward": REWARDS[method]}


def make_task(setup: PushSetup, method: str, case: str):
    """An in-process PlanarPushTask for ``method`` on ``case`` in ``setup.setting`` (its cylinder
    start, ``method``'s reward and, for "tracking", the case's :func:`reference_path`)."""
    from ..sim.planar_arm import PushObject
    from ..tasks.push.task import PlanarPushTask

    reward = reward_for(setup.setting, method)
    ref = reference_path(setup, case) if reward == "tracking" else None
    return PlanarPushTask(setup.n_joints, obj=PushObject(start_xy=setup.setting.start_xy),
                          tolerance=setup.tolerance, reward=reward, reference_path=ref)


def run_push(
    seeds: int | list[int] = 3,
    *,
    train_steps: int = 3000,
    adapt_config: AdaptConfig | None = None,
    promp_config: PrompRLConfig | None = None,
    cases: tuple[str, ...] = CASES,
    methods: tuple[str, ...] = METHODS,
    demo_path: str | None = None,
    evaluator_factory: Callable[[PushSetup, str, str], RolloutEvaluator] | None = None,
    on_iteration: Callable[[str, str, int], Callable] | None = None,
    progress: bool = False,
    log: Callable[[str], None] | None = None,
    setting: PushSetting = PAPER,
    recipe: Recipe = PAPER_METHOD,
) -> dict:
    """Run E2 over several seeds and return the JSON-ready result.

    Parameters
    ----------
    seeds : a count N (seeds 0..N-1) or an explicit list; each seeds CNMP init/training,
        exploration and ProMP sampling.
    train_steps : supervised CNMP training steps (batch 32).
    adapt_config : ACNMP settings (default: ``recipe``'s, :func:`adapt_settings`); ``mode`` is set here.
    promp_config : ProMP + RL settings (default: PrompRLConfig(**PROMP_DEFAULTS)); its seed is
        replaced by each run's seed.
    cases, methods : subsets of CASES and METHODS to run.
    demo_path : demonstration file (default: the cached generated set).
    evaluator_factory : ``(setup, method, case) -> RolloutEvaluator``, called once per (seed,
        method, case), to run :func:`task_config` ``(setup, method)``; default: one in-process
        PlanarPushTask per method shared by all runs (closed at the end).
    on_iteration : ``(method, case, seed) -> callback`` for adapt() (ACNMP only), e.g. to record.
    progress : training progress bars. log : called with one line per finished run.
    setting : the task setting (default :data:`~acnmp_core.tasks.push.settings.PAPER`).
    recipe : ACNMP's method (:mod:`~acnmp_core.experiments.recipe`): the paper's (the default here)
        or the product's default, for its model and its adaptation settings; ProMP + RL is the same
        under both.

    Returns
    -------
    dict with ``experiment`` "push", ``setting`` (its name), ``seeds`` N, ``seed_list``, ``wall_time_s``, ``tolerance`` (m),
    ``targets`` {case: [x, y]}, ``methods`` {method: {case: {rollouts_median, rollouts, success_rate,
    final_error_median, lfd_error_median, lfd_success_rate}}}, ``rollout_ratio_promp_over_acnmp``
    {case: ratio of medians, None unless both methods succeed in more than half of the seeds}, ``config`` (settings used) and ``runs`` (per seed, method and
    case: rollouts, success, final_error, lfd_error, curve [[roll-outs, error], ...]; ACNMP's also
    ``model``, its prior: :func:`~acnmp_core.experiments.recipe.model_prior`), ``recipe``.
    """
    seed_list = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    if not seed_list:
        raise ValueError("seeds: expected at least one seed")
    for c in cases:
        if c not in CASES:
            raise ValueError(f"cases: expected a subset of {CASES}, got {c!r}")
    for m in methods:
        if m not in METHODS:
            raise ValueError(f"methods: expected a subset of {METHODS}, got {m!r}")
    acfg = adapt_config or adapt_settings(recipe)
    pcfg = promp_config or PrompRLConfig(**PROMP_DEFAULTS)
    t0 = time.perf_counter()
    setup = make_setup(demo_path, setting=setting)
    shared: dict[tuple[str, str], RolloutEvaluator] = {}

    def evaluator(method: str, case: str) -> RolloutEvaluator:
        if evaluator_factory is not None:
            return evaluator_factory(setup, method, case)
        # One task per method (per case too when the reward's reference path depends on it).
        key = (method, case if reward_for(setting, method) == "tracking" else "")
        if key not in shared:
            shared[key] = make_task(setup, method, case)
        return shared[key]

    runs: list[dict] = []
    try:
        for seed in seed_list:
            model = train_push_cnmp(setup.demos, seed, train_steps, progress, recipe.prior) if "acnmp" in methods else None
            for method in methods:
                for case in cases:
                    t1 = time.perf_counter()
                    ev = evaluator(method, case)
                    if method == "acnmp":
                        import copy

                        cb = on_iteration(method, case, seed) if on_iteration else None
                        r = {**run_acnmp_case(copy.deepcopy(model), setup, case, ev, acfg, seed, cb),
                             "model": model_prior(model)}
                    else:
                        r = run_promp_case(setup, case, ev, replace(pcfg, seed=seed))
                    record_run(runs, r, seed, method, case, t1, log)
    finally:
        for task in shared.values():
            task.close()

    summary = {m: {c: _summarise([r for r in runs if r["method"] == m and r["case"] == c]) for c in cases}
               for m in methods}
    ratio = {}
    if set(METHODS) <= set(methods):
        for c in cases:
            a, p = summary["acnmp"][c], summary["promp_rl"][c]
            # A ratio of medians says something only when both medians are successful runs.
            both = a["success_rate"] > 0.5 and p["success_rate"] > 0.5
            ratio[c] = round(p["rollouts_median"] / a["rollouts_median"], 3) if both else None
    return {
        "experiment": "push",
        "setting": setting.name,
        "recipe": recipe.to_dict(),
        "seeds": len(seed_list),
        "seed_list": seed_list,
        "wall_time_s": round(time.perf_counter() - t0, 2),
        "tolerance": setup.tolerance,
        "targets": {c: setup.targets[c].tolist() for c in CASES},
        "methods": summary,
        "rollout_ratio_promp_over_acnmp": ratio,
        "config": {"train_steps": train_steps, "rewards": {m: reward_for(setting, m) for m in methods},
                   "acnmp": _plain(vars(acfg)), "promp_rl": _plain(vars(pcfg))},
        "runs": runs,
    }


def _plain(d: dict) -> dict:
    """Config dict with JSON-friendly values (tuples/arrays to lists)."""
    out = {}
    for k, v in d.items():
        if isinstance(v, np.ndarray):
            v = v.tolist()
        elif isinstance(v, tuple):
            v = list(v)
        out[k] = v
    return out


def curve_band(curves: list[list[list[float]]], grid: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Median, 25th and 75th percentile over runs of the error-vs-roll-outs step curves on ``grid``.

    Each curve is [[roll-outs, error], ...] (increasing roll-outs); between measurements the last
    error holds, and after a run stops (success) its last error holds too. Returns three (G,) arrays.
    """
    vals = np.empty((len(curves), len(grid)))
    for i, c in enumerate(curves):
        c = np.asarray(c, dtype=np.float64)
        idx = np.searchsorted(c[:, 0], grid, side="right") - 1
        vals[i] = np.where(idx >= 0, c[np.clip(idx, 0, None), 1], c[0, 1])
    return np.median(vals, axis=0), np.percentile(vals, 25, axis=0), np.percentile(vals, 75, axis=0)
