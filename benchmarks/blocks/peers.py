"""The docs blocks of the peers comparison on Meta-World (peers.json): ACNMP beside SB3, black-box ProMP + CMA-ES and ProMP + RL."""
from __future__ import annotations

import numpy as np

from benchmarks.report_kit import fmt, load, renderer, source, table


PEER_LABELS = {"lfd": "LfD only", "acnmp": "ACNMP", "promp_rl": "ProMP + RL", "promp_cma": "ProMP + CMA-ES",
               "ppo": "PPO", "ppo_bc": "PPO + BC", "sac_bc": "SAC + BC", "sac": "SAC"}
SB3 = ("ppo", "ppo_bc", "sac_bc", "sac")


def _peer_runs(r: dict, task: str, case: str, method: str) -> list[dict]:
    return [x for x in r["runs"] if (x["task"], x["case"], x["method"]) == (task, case, method)]


def _median(runs: list[dict]) -> float:
    """Median episodes, a censored run counting as beyond every number (inf when half or more are)."""
    return float(np.median([x["episodes"] if x["success"] else np.inf for x in runs])) if runs else np.nan


def _short(task: str) -> str:
    return task.removeprefix("metaworld-")


def _peer_block(tbl: str, note: str, r: dict) -> str:
    """A table, its note in italics and the source line."""
    return "\n".join([tbl, "", f"*{note}*", "", source(r, "peers")])


@renderer("peers-losses")
def peers_losses() -> str:
    """Where ACNMP loses: per task and case, the peers whose median episodes are below ACNMP's."""
    r = load("peers")
    lines = []
    for task in r["config"]["tasks"]:
        for case in r["config"]["cases"]:
            acnmp = _peer_runs(r, task, case, "acnmp")
            if not acnmp:
                continue
            a = _median(acnmp)
            for m in r["config"]["methods"]:
                if m in ("acnmp", "lfd"):
                    continue
                runs = _peer_runs(r, task, case, m)
                if runs and _median(runs) < a:
                    ok = sum(x["success"] for x in runs)
                    lines.append(f"* **{_short(task)}, {case}**: {PEER_LABELS[m]} succeeds in {ok} of {len(runs)} with a "
                                 f"median of {fmt(_median(runs))} episode(s); ACNMP in "
                                 f"{sum(x['success'] for x in acnmp)} of {len(acnmp)} with a median of "
                                 + (fmt(a) if np.isfinite(a) else f"> {acnmp[0]['budget']}") + ".")
    return "\n".join(lines or ["* No peer's median is below ACNMP's on any task and case measured."]) + "\n\n" + source(r, "peers")


@renderer("peers-study")
def peers_study() -> str:
    """What the linear peers exploit: the start trajectory's distance to the expert's own path."""
    r = load("peers")
    rows = []
    for task in r["config"]["tasks"]:
        for case in r["config"]["cases"]:
            lfd, cma = _peer_runs(r, task, case, "lfd"), _peer_runs(r, task, case, "promp_cma")
            if not lfd or not cma:
                continue
            path = lambda runs: fmt(float(np.median([x["details"]["path_error_to_expert"] for x in runs])))  # noqa: E731
            first = lambda runs: fmt(float(np.median([x["details"]["lfd_error"] for x in runs])))  # noqa: E731
            rows.append([_short(task), case, len(lfd), path(lfd), path(cma), first(lfd), first(cma),
                         f"{sum(x['success'] for x in lfd)}/{len(lfd)}",
                         f"{sum(x['success'] and x['episodes'] == 1 for x in cma)}/{len(cma)}"])
    return _peer_block(table(["task", "case", "seeds", "CNMP mean to expert (m)", "conditioned ProMP to expert (m)",
                              "CNMP first episode's error (m)", "ProMP first episode's error (m)",
                              "CNMP succeeds at once", "ProMP succeeds at once"], rows),
                       "Distances: root mean square over the 100 steps of the hand's distance (x, y, z) between the "
                       "trajectory each method starts from and the scripted expert's own hand path at the test "
                       "position; medians over the seeds. Errors: the smallest distance to the goal (reach) or of the "
                       "puck to the goal (push, pick-place) in the first executed episode, medians.", r)


@renderer("peers-results")
def peers_results() -> str:
    """The comparison's table: per task, case and method, successes, median episodes, per seed, wall time."""
    r = load("peers")
    rows = []
    for task in r["config"]["tasks"]:
        for case in r["config"]["cases"]:
            for m in r["config"]["methods"]:
                runs = sorted(_peer_runs(r, task, case, m), key=lambda x: x["seed"])
                if not runs:
                    continue
                med = _median(runs)
                budgets = sorted({x["budget"] for x in runs})
                rows.append([_short(task), case, PEER_LABELS[m], f"{sum(x['success'] for x in runs)}/{len(runs)}",
                             fmt(med) if np.isfinite(med) else f"> {max(budgets)}",
                             ", ".join(x["shown"] for x in runs), "/".join(map(str, budgets)),
                             fmt(float(np.median([x["time_s"] for x in runs])))])
    return _peer_block(table(["task", "case", "method", "success", "episodes (median)", "per seed (0, 1, ...)",
                              "budget", "wall time (median, s)"], rows),
                       "Episodes: executed until the method's deterministic output first succeeded, evaluation "
                       "episodes included; \"> B\": no success within the budget B (a median is \"> B\" when half of "
                       "the runs or more are). Wall time per run on the shared 2-core machine, without the CNMP's "
                       "training (LfD only, ACNMP).", r)


@renderer("peers-targets")
def peers_targets() -> str:
    """The issue's decided targets, each met, missed or not measured, from peers.json."""
    r = load("peers")
    lines = []
    for task in r["config"]["tasks"]:
        lfd, acnmp = _peer_runs(r, task, "extrapolation", "lfd"), _peer_runs(r, task, "extrapolation", "acnmp")
        if not lfd or not acnmp:
            lines.append(f"* {_short(task)}: not measured.")
            continue
        fails, ok, n = sum(not x["success"] for x in lfd), sum(x["success"] for x in acnmp), len(acnmp)
        a = _median(acnmp)
        t1 = (f"LfD only fails in {fails} of {len(lfd)}" + (f", so ACNMP must succeed in at least 4 of 5: {ok} of {n}, "
              f"{'met' if ok >= 4 * n / 5 else 'missed'}" if fails >= 3 * len(lfd) / 5 else " (the target applies "
              "from 3 of 5)"))
        cma = _peer_runs(r, task, "extrapolation", "promp_cma")
        c = _median(cma)
        t3 = ("ProMP + CMA-ES not run" if not cma else
              f"ACNMP's median {fmt(a) if np.isfinite(a) else '> budget'} against ProMP + CMA-ES's "
              f"{fmt(c) if np.isfinite(c) else '> budget'}: {'met' if a <= c else 'missed'}")
        sb3 = {m: _peer_runs(r, task, "extrapolation", m) for m in SB3 if _peer_runs(r, task, "extrapolation", m)}
        if not sb3:
            t2 = "no SB3 run made"
        else:
            parts = []
            for m, runs in sb3.items():
                med = _median(runs)
                verdict = ("not succeeding within its budget" if not np.isfinite(med) else
                           f"median {fmt(med)}, {'met' if a <= med / 10 else 'missed'}")
                parts.append(f"{PEER_LABELS[m]} ({len(runs)} seed(s), budget {max(x['budget'] for x in runs)}): "
                             f"{sum(x['success'] for x in runs)} succeeded, {verdict}")
            t2 = "; ".join(parts)
        lines.append(f"* **{_short(task)}** (extrapolation): {t1}. Against SB3 (ACNMP's median at most a tenth of "
                     f"the best variant's, or it does not succeed within its budget): {t2}. {t3}.")
    missing = len(r.get("not_run", []))
    lines += ["", f"*Runs planned but not made: {missing} (listed under `not_run` in the JSON).*" if missing else
              "*Every planned run was made.*", "", source(r, "peers")]
    return "\n".join(lines)
