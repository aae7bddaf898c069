"""The Gymnasium worked example: MuJoCo ``Pusher-v5``, a 7-DoF arm pushing a cylinder to a goal,
extrapolated beyond its demonstrations (issue 33; the standard environment closest to E2).

Per seed: a CNMP (joint targets (100, 7) rad over phase, task parameters (object x, y, goal x, y)
m) is trained on the 12 scripted demonstrations of
:mod:`~acnmp_core.tasks.pusher.scene` (training region), and one test position is drawn from the
extrapolation region (0.20-0.25 m beyond the demonstrations) with the seed's generator. Three
methods face it, all executing on the ``pusher`` robot (:mod:`acnmp_core.robots.pusher`):

* **LfD-only**: the CNMP's mean trajectory for the test position, executed once;
* **ACNMP**: that roll-out, then :func:`~acnmp_core.adaptation.loop.adapt` (RL with simultaneous SL on
  the demonstrations) until success or :data:`ACNMP_BUDGET` roll-outs;
* **ProMP + RL**: :func:`~acnmp_core.baselines.promp_rl.adapt_promp` from the nearest demonstration, episodic
  REPS, until success or :data:`PROMP_BUDGET` roll-outs (E2's baseline settings).

Success: the object's final distance to the goal is at most
:data:`~acnmp_core.tasks.pusher.scene.PUSHER_SUCCESS_M` (0.05 m). Rewards: Pusher's own per step.
The per-method code is E2's (:mod:`acnmp_core.experiments.push`), whose setup type fits any task
"demonstrations, test targets as task parameters, a start posture".
"""
from __future__ import annotations

import copy
import time
from dataclasses import replace
from typing import Callable

import numpy as np

from ..adaptation.config import AdaptConfig
from ..baselines.promp_rl import PrompRLConfig
from ..model.cnmp import CNMP, CNMPConfig
from ..model.training import TrainConfig, train
from ..rollout import RolloutEvaluator
from .push import PROMP_DEFAULTS, PushSetup, _plain, _summarise, record_run, run_acnmp_case, run_promp_case

METHODS = ("lfd", "acnmp", "promp_rl")
CASE = "extrapolation"
#: ACNMP's roll-out budget per test position (stated before measuring, docs/experiments/pusher.md)
ACNMP_BUDGET = 400
#: ProMP + RL's roll-out budget per test position (E2's)
PROMP_BUDGET = 1500
#: CNMP training steps
TRAIN_STEPS = 3000


def test_params(seed: int) -> np.ndarray:
    """(4,) m: seed ``seed``'s test position, drawn from the extrapolation region."""
    from ..tasks.pusher.scene import extrapolation_params

    return extrapolation_params(1, np.random.default_rng(seed))[0]


def make_setup(seed: int, demos=None) -> PushSetup:
    """The demonstrations (generated, ~2 s, unless ``demos`` DemoArrays are given) and seed's test position."""
    from ..tasks.pusher.scene import PUSHER_SUCCESS_M, pusher_demos

    arrays = demos if demos is not None else pusher_demos()
    return PushSetup(demos=arrays.to_demo_set(), targets={CASE: test_params(seed)}, times=arrays.times[0].copy(),
                     q0=arrays.values[0, 0].copy(), n_joints=arrays.values.shape[2], tolerance=PUSHER_SUCCESS_M,
                     demo_arrays=arrays)


def train_pusher_cnmp(setup: PushSetup, seed: int, steps: int = TRAIN_STEPS, progress: bool = False) -> CNMP:
    """The LfD model: a default-size CNMP over the 7 joints with the 4 task parameters."""
    names = setup.demo_arrays.value_names
    model = CNMP(CNMPConfig(n_outputs=setup.demos.n_outputs, n_task_params=setup.demos.n_task_params,
                            output_names=None if names is None else [str(n) for n in names],
                            task_param_names=["object_x", "object_y", "goal_x", "goal_y"], prior="none"), seed=seed)
    train(model, setup.demos, TrainConfig(steps=steps), seed=seed, progress=progress)
    return model


def run_pusher(seeds: int | list[int] = 10, *, train_steps: int = TRAIN_STEPS, acnmp_budget: int = ACNMP_BUDGET,
               promp_budget: int = PROMP_BUDGET, methods: tuple[str, ...] = METHODS,
               evaluator_factory: Callable[[str, int], RolloutEvaluator] | None = None,
               progress: bool = False, log: Callable[[str], None] | None = None) -> dict:
    """Run the Pusher example over ``seeds`` (a count N: seeds 0..N-1, or a list) and return the
    JSON-ready result.

    evaluator_factory : ``(method, seed) -> RolloutEvaluator`` executing the ``pusher_push`` task
        (e.g. on remote workers); default: one in-process evaluator shared by every run.
    Returns ``experiment`` "pusher", ``seed_list``, ``wall_time_s``, ``tolerance`` (m), ``budgets``,
    ``methods`` {method: {rollouts_median, rollouts, success_rate, final_error_median,
    lfd_error_median, lfd_success_rate}}, ``rollout_ratio_promp_over_acnmp`` (None unless both
    succeed in more than half of the seeds), ``config`` and ``runs`` (per seed and method: the test
    position, roll-outs, success, final error, curve).
    """
    from ..robots.registry import robot

    seed_list = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    unknown = sorted(set(methods) - set(METHODS))
    if not seed_list or unknown:
        raise ValueError(f"seeds/methods: expected at least one seed and methods among {METHODS}, got {unknown}")
    from ..tasks.pusher.scene import pusher_demos

    t0 = time.perf_counter()
    demos = pusher_demos()
    shared = None if evaluator_factory is not None else robot("pusher").make_evaluator("pusher_push")
    acfg = AdaptConfig.paper(max_rollouts=acnmp_budget)
    pcfg = PrompRLConfig(**{**PROMP_DEFAULTS, "max_rollouts": promp_budget})
    runs: list[dict] = []
    try:
        for seed in seed_list:
            setup = make_setup(seed, demos)
            ev = (lambda method: evaluator_factory(method, seed)) if shared is None else (lambda method: shared)
            if {"lfd", "acnmp"} & set(methods):
                t1 = time.perf_counter()
                model = train_pusher_cnmp(setup, seed, train_steps, progress)
                # ACNMP's first roll-out is the LfD trajectory: LfD-only is that roll-out alone
                lfd_cfg = replace(acfg, max_rollouts=1)
                for method, cfg in (("lfd", lfd_cfg), ("acnmp", acfg)):
                    if method in methods:
                        t2 = time.perf_counter() if method == "acnmp" else t1
                        r = run_acnmp_case(copy.deepcopy(model), setup, CASE, ev(method), cfg, seed)
                        record_run(runs, {**r, "params": setup.targets[CASE].tolist()}, seed, method, CASE, t2, log)
            if "promp_rl" in methods:
                t1 = time.perf_counter()
                r = run_promp_case(setup, CASE, ev("promp_rl"), replace(pcfg, seed=seed))
                record_run(runs, {**r, "params": setup.targets[CASE].tolist()}, seed, "promp_rl", CASE, t1, log)
    finally:
        if shared is not None:
            shared.close()
    summary = {m: _summarise([r for r in runs if r["method"] == m]) for m in methods}
    ratio = None
    if {"acnmp", "promp_rl"} <= set(methods):
        a, p = summary["acnmp"], summary["promp_rl"]
        if a["success_rate"] > 0.5 and p["success_rate"] > 0.5:
            ratio = round(p["rollouts_median"] / a["rollouts_median"], 3)
    from ..tasks.pusher.scene import EXTRAPOLATION_REGION, PUSHER_SUCCESS_M, TRAINING_REGION

    return {
        "experiment": "pusher", "seeds": len(seed_list), "seed_list": seed_list,
        "wall_time_s": round(time.perf_counter() - t0, 2), "tolerance": PUSHER_SUCCESS_M,
        "budgets": {"acnmp": acnmp_budget, "promp_rl": promp_budget},
        "regions": {"training": vars(TRAINING_REGION), "extrapolation": vars(EXTRAPOLATION_REGION)},
        "methods": summary, "rollout_ratio_promp_over_acnmp": ratio,
        "config": {"train_steps": train_steps, "n_demos": int(demos.values.shape[0]),
                   "acnmp": _plain(vars(acfg)), "promp_rl": _plain(vars(pcfg))},
        "runs": runs,
    }


def plot_pusher(result: dict, path) -> "object":
    """Write the figure: the object's final distance to the goal per seed and method (the success
    threshold dashed), and the roll-outs each adaptive method used per seed (hollow: failed within
    its budget). Returns the path."""
    from pathlib import Path

    from .figures import pyplot, save_figure

    plt = pyplot()

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    colors = {"lfd": "tab:red", "acnmp": "tab:green", "promp_rl": "tab:blue"}
    labels = {"lfd": "LfD only", "acnmp": "ACNMP", "promp_rl": "ProMP + RL"}
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8))
    for m in result["methods"]:
        runs = [r for r in result["runs"] if r["method"] == m]
        seeds = [r["seed"] for r in runs]
        ax1.plot(seeds, [r["final_error"] for r in runs], "o", color=colors[m], label=labels[m])
        if m != "lfd":
            for r in runs:
                ax2.plot(r["seed"], r["rollouts"], "o", color=colors[m], mfc=colors[m] if r["success"] else "none",
                         label=labels[m] if r is runs[0] else None)
    ax1.axhline(result["tolerance"], color="k", ls="--", lw=1, label="success threshold")
    ax1.set_xlabel("seed (one test position each)")
    ax1.set_ylabel("object's final distance to the goal (m)")
    ax1.legend(fontsize=8)
    ax2.set_xlabel("seed")
    ax2.set_ylabel("roll-outs (hollow: failed)")
    ax2.set_yscale("log")
    ax2.legend(fontsize=8)
    fig.suptitle(f"Pusher-v5, extrapolated positions, {result['seeds']} seed(s)")
    return save_figure(fig, path)
