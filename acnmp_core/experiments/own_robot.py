"""Any robot, your demonstrations: LfD only against ACNMP at task parameters you name.

The experiment a user runs on a robot of their own (a plugin, a Gymnasium environment): a CNMP is
trained on a demonstration file (the project's .npz format) and, per seed and per test point
(task parameters (P,)), its mean trajectory, conditioned on the demonstrations' start at t = 0,
is executed once (LfD only) and then adapted by ACNMP until the task says success or the budget
runs out, on the robot's task (:mod:`acnmp_core.robots.registry`). The per-case code is E2's
(:mod:`acnmp_core.experiments.push`).
"""
from __future__ import annotations

import copy
import time
from dataclasses import replace
from typing import Callable, Sequence

import numpy as np

from ..adaptation.config import AdaptConfig
from ..data.demo_io import DemoArrays
from ..errors import InputError
from ..model.cnmp import CNMP, CNMPConfig
from ..model.training import TrainConfig, train
from ..rollout import RolloutEvaluator
from .push import PushSetup, _summarise, record_run, run_acnmp_case

METHODS = ("lfd", "acnmp")


def robot_task(kind: str, task: str | None) -> str:
    """The task to run on robot ``kind``: ``task``, or the robot's only task; InputError otherwise."""
    from ..robots.registry import robot

    tasks = sorted(robot(kind).tasks)
    if task is None:
        if len(tasks) != 1:
            raise InputError(f"task: robot {kind!r} runs {tasks}; name one")
        return tasks[0]
    if task not in tasks:
        raise InputError(f"task: robot {kind!r} runs {tasks}, not {task!r}")
    return task


def check_points(demos: DemoArrays, points: Sequence[Sequence[float]], name: str = "points") -> list[np.ndarray]:
    """The test points as arrays (P,), P the demonstrations' task parameters; InputError, its
    message starting with ``name``, when there is none or one has another length: the message
    says what was given and shows the first demonstration's task parameters as an example."""
    n_params = demos.task_params.shape[1]
    pts = [np.asarray(p, dtype=np.float64).reshape(-1) for p in points]
    bad = [p for p in pts if p.shape != (n_params,)]
    if pts and not bad:
        return pts
    names = "" if demos.task_param_names is None else f" ({', '.join(demos.task_param_names)})"
    given = "none" if not pts else "; ".join(f"{_csv(p)} ({p.size} value{'s' * (p.size != 1)})" for p in bad)
    option = f"{name} " if name.startswith("-") else ""  # a command-line option: the example is one
    example = (f"e.g. {option}{_csv(demos.task_params[0])}, the first demonstration's" if n_params else
               "but the demonstrations have none, so there is nothing to vary")
    raise InputError(f"{name}: expected points of {n_params} comma-separated task parameters{names}, as the "
                     f"demonstrations have ({example}); got {given}")


def _csv(values) -> str:
    """Numbers as the command line takes them: ``0.6,0.45``."""
    return ",".join(f"{float(v):g}" for v in values)


def run_own_robot(kind: str, demos: DemoArrays, points: Sequence[Sequence[float]], *, task: str | None = None,
                  task_config: dict | None = None, seeds: int | list[int] = 1, train_steps: int = 3000,
                  budget: int = 300, evaluator_factory: Callable[[str, int, int], RolloutEvaluator] | None = None,
                  log: Callable[[str], None] | None = None) -> dict:
    """LfD only and ACNMP at each test point (P,) of ``points`` on robot ``kind`` (see the module).

    demos : N demonstrations, times (N, T), values (N, T, D), task parameters (N, P); every
        demonstration's first row is taken as the start the model is conditioned on (their mean).
    evaluator_factory : ``(method, seed, point index) -> RolloutEvaluator`` (e.g. remote workers);
        default: one in-process evaluator of the task shared by every run.
    Returns ``experiment`` "robot", ``robot``, ``task``, ``points``, ``seed_list``, ``wall_time_s``,
    ``methods`` {method: summary over every seed and point}, ``runs`` (per seed, point and method).
    """
    from ..robots.registry import robot

    task = robot_task(kind, task)
    spec = robot(kind)
    pts = check_points(demos, points)
    seed_list = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    if not seed_list:
        raise InputError("seeds: expected at least one seed")
    if demos.lengths is not None and np.any(demos.lengths != demos.times.shape[1]):
        raise InputError("demos: demonstrations of different lengths are not supported here")
    t0 = time.perf_counter()
    shared = None if evaluator_factory is not None else spec.make_evaluator(task, task_config)
    cfg = AdaptConfig(max_rollouts=budget)
    demo_set = demos.to_demo_set()
    runs: list[dict] = []
    try:
        for seed in seed_list:
            model = CNMP(CNMPConfig(n_outputs=demos.values.shape[2], n_task_params=demos.task_params.shape[1]), seed=seed)
            train(model, demo_set, TrainConfig(steps=train_steps), seed=seed)
            for i, point in enumerate(pts):
                case = f"point{i}"
                setup = PushSetup(demos=demo_set, targets={case: point}, times=demos.times[0].copy(),
                                  q0=demos.values[:, 0].mean(axis=0), n_joints=demos.values.shape[2], tolerance=0.0)
                for method, c in (("lfd", replace(cfg, max_rollouts=1)), ("acnmp", cfg)):
                    ev = shared if shared is not None else evaluator_factory(method, seed, i)
                    t1 = time.perf_counter()
                    r = run_acnmp_case(copy.deepcopy(model), setup, case, ev, c, seed)
                    record_run(runs, {**r, "point": point.tolist()}, seed, method, case, t1, log)
    finally:
        if shared is not None and hasattr(shared, "close"):
            shared.close()
    return {"experiment": "robot", "robot": kind, "task": task, "task_config": dict(task_config or {}),
            "points": [p.tolist() for p in pts], "seeds": len(seed_list), "seed_list": seed_list,
            "wall_time_s": round(time.perf_counter() - t0, 2), "budget": budget, "train_steps": train_steps,
            "methods": {m: _summarise([r for r in runs if r["method"] == m]) for m in METHODS}, "runs": runs}


def plot_own_robot(result: dict, path) -> "object":
    """Write the figure of :func:`run_own_robot`'s result: per test point, the task's remaining
    error after LfD only and after ACNMP (one marker per seed), and the roll-outs ACNMP used
    (hollow: it did not succeed within the budget). Returns the path."""
    from pathlib import Path

    from .figures import pyplot, save_figure

    plt = pyplot()

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8))
    for offset, (method, color, label) in zip((-0.1, 0.1), (("lfd", "tab:red", "LfD only"), ("acnmp", "tab:green", "ACNMP"))):
        runs = [r for r in result["runs"] if r["method"] == method]
        x = [int(r["case"].removeprefix("point")) + offset for r in runs]
        ax1.plot(x, [r["final_error"] for r in runs], "o", color=color, label=label)
        if method == "acnmp":
            for xi, r in zip(x, runs):
                ax2.plot(xi, r["rollouts"], "o", color=color, mfc=color if r["success"] else "none")
    ticks = range(len(result["points"]))
    labels = [", ".join(f"{v:g}" for v in p) for p in result["points"]]
    for ax in (ax1, ax2):
        ax.set_xticks(list(ticks), labels, fontsize=8)
        ax.set_xlabel("test point (task parameters)")
    ax1.set_ylabel("remaining error (the task's units)")
    ax1.legend(fontsize=8)
    ax2.set_ylabel(f"ACNMP roll-outs (budget {result['budget']}; hollow: failed)")
    fig.suptitle(f"robot {result['robot']}, task {result['task']}, {result['seeds']} seed(s)")
    return save_figure(fig, path)
