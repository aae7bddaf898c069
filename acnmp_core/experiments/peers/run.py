"""Running the peers comparison: the plan, the runs written one by one, the summary, merging parts."""
from __future__ import annotations

import json
import os
import time
from dataclasses import asdict
from pathlib import Path
from typing import Callable

import numpy as np

from ...errors import InputError
from .config import (CASES, FAMILY_TASKS, METHODS, STEP_BASED_METHODS, TASK_NAMES, TRAJECTORY_METHODS, PeerRun, PeersConfig,
                     library_versions, mean_episodes, median_episodes)
from .tasks import PeerTask, peer_task

Item = tuple[str, int, str, str]  # (task, seed, case, method)


def plan(config: PeersConfig, not_applicable: Callable[[str], dict[str, str]] | None = None) -> list[Item]:
    """(task, seed, case, method) in the order :func:`run_peers` runs them: the trajectory methods
    first (task by task, seed by seed, each case the task has, in :data:`~.config.TRAJECTORY_METHODS`
    order), then the stable-baselines3 methods
    (method by method, then task, case and seed). A method that does not apply to a task
    (``not_applicable(task)``: method -> why; default: the tasks' own) is left out."""
    not_applicable = not_applicable or _not_applicable
    cases = {t: [c for c in config.cases if c in _cases(t)] for t in config.tasks}
    traj = [(t, s, c, m) for t in config.tasks for s in config.seeds for c in cases[t]
            for m in TRAJECTORY_METHODS if m in config.methods and m not in not_applicable(t)]
    steps = [(t, s, c, m) for m in STEP_BASED_METHODS if m in config.methods for t in config.tasks
             if m not in not_applicable(t) for c in cases[t] for s in config.seeds]
    return traj + steps


def _task_class(name: str) -> type[PeerTask]:
    from .tasks import FamilyPeer, HolePeer, MetaWorldPeer, PushPeer, PusherPeer, ViaPointPeer

    if name in FAMILY_TASKS:
        return FamilyPeer
    return {c.name: c for c in (ViaPointPeer, PushPeer, PusherPeer, HolePeer)}.get(name, MetaWorldPeer)


def _cases(name: str) -> tuple[str, ...]:
    return _task_class(name).cases


def _not_applicable(name: str) -> dict[str, str]:
    return _task_class(name).inapplicable()


def summarise(runs: list[PeerRun]) -> dict:
    """Per task, case and method: ``runs``, ``successes``, ``median_episodes`` (None when half of the
    runs or more are censored: the median is then beyond the budget, ``median_shown`` "> budget"),
    ``mean_episodes`` (a censored run counting its budget: then ``mean_is_lower_bound``),
    ``median_time_s``, ``budget`` (the largest), ``seeds``."""
    out: dict = {}
    for r in runs:
        out.setdefault(r.task, {}).setdefault(r.case, {}).setdefault(r.method, []).append(r)
    summary: dict = {}
    for task, cases in out.items():
        for case, methods in cases.items():
            for method, rs in methods.items():
                median = median_episodes(rs)
                mean, censored = mean_episodes(rs)
                budget = max(r.budget for r in rs)
                summary.setdefault(task, {}).setdefault(case, {})[method] = {
                    "runs": len(rs), "successes": int(sum(r.success for r in rs)),
                    "median_episodes": None if not np.isfinite(median) else median,
                    "median_shown": f"> {budget}" if not np.isfinite(median) else f"{median:g}",
                    "mean_episodes": round(mean, 2), "mean_is_lower_bound": censored,
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


def _settings(tasks: dict[str, PeerTask]) -> dict:
    """Per task, what was chosen on its demonstrations (:meth:`~.tasks.PeerTask.chosen_settings`)."""
    return {name: chosen for name, t in tasks.items() if (chosen := t.chosen_settings())}


def run_peers(config: PeersConfig, *, out: str | Path | None = None, resume: bool = False,
              header: dict | None = None, on_run: Callable[[PeerRun], None] | None = None,
              progress: bool = False,
              run_method: Callable[[PeerTask, PeersConfig, int, str, str, dict], PeerRun] | None = None,
              make_task: Callable[[str], PeerTask] = peer_task, commit: str | None = None) -> dict:
    """Run :func:`plan`'s runs and return the JSON-ready result: ``experiment`` "peers", ``config``,
    ``versions`` (:func:`~.config.library_versions`), ``not_applicable`` (per task: method -> why),
    ``settings`` (per task, what was chosen on the demonstrations), ``runs`` (:class:`PeerRun` as
    JSON, with ``censored`` and ``shown``), ``summary`` (:func:`summarise`), ``not_run`` (the
    planned runs missing), ``wall_time_s``: the sum of every run's whole wall time
    (:attr:`PeerRun.whole_wall_s`: its training and its task's set-up included), the resumed runs' too.

    out : the result is written there after every run (and at the end). resume : runs already in
    ``out`` (same task, method, seed, case) are kept and not run again; InputError when one of them
    was made at another commit than ``commit`` (a result of record is made at one). header : entries
    put first (e.g. provenance). on_run : called with each finished run. run_method, make_task :
    what runs a method and builds a task (default :func:`~.methods.run_method`,
    :func:`~.tasks.peer_task`). commit : the commit the runs are made at, recorded in each.
    """
    from .methods import run_method as default_run

    run_method = run_method or default_run
    path = None if out is None else Path(out)
    runs = load_runs(path) if (resume and path is not None) else []
    check_one_commit(runs, commit, path)
    settings = json.loads(path.read_text()).get("settings", {}) if (resume and path is not None and runs) else {}
    done = {r.key for r in runs}
    planned = plan(config)
    todo = [item for item in planned if (item[0], item[3], item[1], item[2]) not in done]
    tasks: dict[str, PeerTask] = {}

    def result() -> dict:
        have = {r.key for r in runs}
        missing = [dict(zip(("task", "seed", "case", "method"), item)) for item in planned
                   if (item[0], item[3], item[1], item[2]) not in have]
        return {**(header or {}), "experiment": "peers", "config": asdict(config), "versions": library_versions(),
                "not_applicable": {t: _not_applicable(t) for t in config.tasks},
                "settings": {**settings, **_settings(tasks)},
                "wall_time_s": round(sum(r.whole_wall_s for r in runs), 1),
                "runs": [r.to_json() for r in runs], "summary": summarise(runs), "not_run": missing}

    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=len(todo), desc="peers", unit="run")
    state: dict = {}
    try:
        for kind, seed, case, method in todo:
            t0 = time.perf_counter()
            if kind not in tasks:
                for other in list(tasks):  # one task's simulators at a time
                    settings.update(_settings({other: tasks[other]}))
                    tasks.pop(other).close()
                tasks[kind] = make_task(kind)
            r = run_method(tasks[kind], config, seed, case, method, state)
            r.wall_s, r.commit = round(time.perf_counter() - t0, 2), commit
            runs.append(r)
            if path is not None:
                _write(path, result())
            if bar is not None:
                bar.update(1)
            if on_run:
                on_run(r)
    finally:
        if bar is not None:
            bar.close()
        for t in tasks.values():
            t.close()
    final = result()
    if path is not None:
        _write(path, final)
    return final


def check_one_commit(runs: list[PeerRun], commit: str | None, path: Path | None) -> None:
    """InputError when a run of ``runs`` (kept from ``path`` to resume) was made at another commit
    than ``commit``, or did not record its commit: resuming would mix code versions in one result."""
    other = sorted({str(r.commit) for r in runs if r.commit != commit})
    if runs and other:
        n = sum(r.commit != commit for r in runs)
        raise InputError(f"{path}: {n} of its {len(runs)} runs were made at commit {', '.join(other)}, not at "
                         f"{commit}; a result is made at one commit: resume at theirs, or start anew")


def run_line(r: PeerRun) -> str:
    """One line per finished run, for the command's log."""
    err = r.details.get("final_error")
    return (f"{r.task:<22} seed {r.seed} {r.case:<13} {r.method:<11} episodes {r.shown:>7} "
            f"success {str(r.success):<5} error {'-' if err is None else f'{err:.3f}'} {r.time_s:.1f} s")


def merge_results(results: list[dict], header: dict | None = None) -> dict:
    """One result of several :func:`run_peers` results made at one commit (e.g. processes run side by
    side on parts of the plan): their runs (a (task, method, seed, case) twice: ValueError), the
    union of their tasks, methods, seeds and cases, the summary again, the summed wall time, their
    settings and each part's ``provenance`` and ``config`` under ``parts``; ``not_run`` lists the
    runs some part planned and no part made."""
    runs: dict[tuple, PeerRun] = {}
    for res in results:
        for r in map(PeerRun.from_json, res["runs"]):
            if r.key in runs:
                raise ValueError(f"merge: {r.key} is in two results")
            runs[r.key] = r
    first = results[0]
    config = dict(first["config"])
    for key, order in (("tasks", TASK_NAMES), ("methods", METHODS), ("seeds", None), ("cases", CASES)):
        values = {v for res in results for v in res["config"][key]}
        config[key] = sorted(values, key=(order.index if order else None) or (lambda v: v))
    merged = sorted(runs.values(), key=lambda r: (config["tasks"].index(r.task), METHODS.index(r.method), r.case, r.seed))
    missing, seen = [], set()
    for res in results:
        for x in res["not_run"]:
            item = (x["task"], x["method"], x["seed"], x["case"])
            if item not in runs and item not in seen:
                seen.add(item)
                missing.append(x)
    return {**(header or {}), "experiment": "peers", "config": config, "versions": first["versions"],
            "not_applicable": {k: v for res in results for k, v in res.get("not_applicable", {}).items()},
            "settings": {k: v for res in results for k, v in res.get("settings", {}).items()},
            "wall_time_s": round(sum(res["wall_time_s"] for res in results), 1),
            "runs": [r.to_json() for r in merged], "summary": summarise(merged), "not_run": missing,
            "parts": [{"provenance": res.get("provenance"), "config": res["config"], "wall_time_s": res["wall_time_s"]}
                      for res in results]}
