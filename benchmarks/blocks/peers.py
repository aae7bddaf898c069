"""The docs blocks of the comparison of record (peers.json): ACNMP, the product's default and the
paper's method, beside LfD only, ProMP + RL, black-box ProMP + CMA-ES and stable-baselines3 on
Meta-World's five tasks, the paper's E1 and E2, and Pusher-v5."""
from __future__ import annotations

import numpy as np

from benchmarks.report_kit import fmt, load, renderer, source, table
from clients.experiments.targets import _median_episodes, peers_verdicts

PEER_LABELS = {"lfd": "LfD only", "lfd_paper": "LfD only (paper's CNMP)", "acnmp": "**ACNMP (default)**",
               "acnmp_paper": "ACNMP (paper's method)", "promp_rl": "ProMP + RL", "promp_cma": "ProMP + CMA-ES",
               "promp_cma5": "ProMP + CMA-ES, 5 bases", "ppo": "PPO", "ppo_bc": "PPO + BC", "sac_bc": "SAC + BC",
               "sac": "SAC"}


def _runs(r: dict, task: str, case: str, method: str) -> list[dict]:
    return sorted((x for x in r["runs"] if (x["task"], x["case"], x["method"]) == (task, case, method)),
                  key=lambda x: x["seed"])


def _short(task: str) -> str:
    return task.removeprefix("metaworld-")


def _median_shown(median: float, budget: int) -> str:
    return fmt(median) if np.isfinite(median) else f"> {budget}"


def _budget(r: dict) -> int:
    return int(r["config"]["budget"])


def _block(tbl: str, note: str, *sources: str) -> str:
    """A table, its note in italics and the source lines."""
    return "\n".join([tbl, "", f"*{note}*", "", *[x for s in sources for x in (s, "")]]).rstrip()


@renderer("peers-verdict")
def peers_verdict() -> str:
    """Issue 64's target on every task and case, the misses first: the default against the best
    peer (successes, median episodes), then the paper's method against the same peers."""
    r = load("peers")
    b = _budget(r)
    lines = []
    for method, who in (("acnmp", "The default"), ("acnmp_paper", "The paper's method")):
        verdicts = peers_verdicts(r, method)
        met = [v for v in verdicts if v["met"]]
        lines.append(f"* **{who}** is at least as good as the best peer on **{len(met)} of {len(verdicts)}** "
                     "tasks and cases (as many successes and a median of episodes no larger, ties counting).")
        for v in sorted(verdicts, key=lambda v: v["met"]):
            if method == "acnmp_paper" and v["met"]:
                continue
            sign = "meets" if v["met"] else "**misses**"
            lines.append(f"  * {_short(v['task'])}, {v['case']}: {sign}: {v['successes']}/{v['runs']}, median "
                         f"{_median_shown(v['median'], b)}; best peer {PEER_LABELS[v['by_successes']]} "
                         f"{v['peer_successes']}/{v['runs']}"
                         + ("" if v["by_median"] == v["by_successes"] else f", {PEER_LABELS[v['by_median']]}")
                         + f" median {_median_shown(v['peer_median'], b)}")
    return "\n".join(lines) + "\n\n" + source(r, "peers")


@renderer("peers-results")
def peers_results() -> str:
    """The comparison's table: per task, case and method, successes, median episodes, per seed, wall time."""
    r = load("peers")
    rows = []
    for task in r["config"]["tasks"]:
        for case in r["config"]["cases"]:
            for m in r["config"]["methods"]:
                runs = _runs(r, task, case, m)
                if not runs:
                    continue
                med = _median_episodes(runs)
                rows.append([_short(task), case, PEER_LABELS[m], f"{sum(x['success'] for x in runs)}/{len(runs)}",
                             _median_shown(med, max(x["budget"] for x in runs)), ", ".join(x["shown"] for x in runs),
                             fmt(float(np.median([x["time_s"] for x in runs])))])
    return _block(table(["task", "case", "method", "success", "episodes (median)", "per seed (0, 1, ...)",
                         "wall time (median, s)"], rows),
                  "Episodes: executed until the method's deterministic output first succeeded, evaluation "
                  "episodes included; \"> B\": no success within the budget B (a median is \"> B\" when half of "
                  f"the runs or more are). Budget: {_budget(r)} episodes for every adaptive method, one for LfD "
                  "only. Wall time per run on the shared 2-core machine, without the CNMP's training.",
                  source(r, "peers"))


@renderer("peers-settings")
def peers_settings() -> str:
    """What each task's demonstrations chose: ProMP + CMA-ES's basis count (leave-one-out error of
    each candidate) and the default model's linear path's; and the methods that do not apply."""
    r = load("peers")
    rows = []
    for task in r["config"]["tasks"]:
        s = r["settings"].get(task, {})
        loo = s.get("promp_cma_basis_loo") or {}
        prior = sorted({x["details"].get("prior_basis") for x in r["runs"] if x["task"] == task and x["method"] == "acnmp"})
        rows.append([_short(task), s.get("promp_cma_basis", "-"),
                     ", ".join(f"{k}: {v:.3f}" for k, v in sorted(loo.items(), key=lambda kv: int(kv[0]))) or "-",
                     ", ".join(map(str, prior)) or "-",
                     "; ".join(f"{PEER_LABELS[m]}: {why}" for m, why in r["not_applicable"].get(task, {}).items()
                               if m in r["config"]["methods"]) or "-"])
    return _block(table(["task", "ProMP + CMA-ES bases (chosen)", "leave-one-out error per basis count",
                         "default model's linear path: bases", "not applicable, and why"], rows),
                  "Both basis counts are chosen on the demonstrations alone: each held out in turn, the "
                  "model of the others conditioned on its task parameters and start (E1, without task "
                  "parameters: its start, middle and end), the error in units of each output's standard "
                  "deviation; the smallest mean error wins. No test position enters the choice.",
                  source(r, "peers"))


@renderer("peers-study")
def peers_study() -> str:
    """What the linear conditioning buys: the trajectory each method starts from against the
    expert's own at the test condition, and how often it succeeds at once."""
    r = load("peers")
    rows = []
    for task in r["config"]["tasks"]:
        for case in r["config"]["cases"]:
            cols = {m: _runs(r, task, case, m) for m in ("lfd", "lfd_paper", "promp_cma")}
            if not all(cols.values()):
                continue
            path = lambda runs: fmt(float(np.median([x["details"]["path_error_to_expert"] for x in runs])))  # noqa: E731
            once = lambda runs: f"{sum(x['success'] and x['episodes'] == 1 for x in runs)}/{len(runs)}"  # noqa: E731
            unit = "rad" if task in ("e2-push", "pusher") else "m"
            rows.append([_short(task), case, unit, path(cols["lfd"]), path(cols["lfd_paper"]), path(cols["promp_cma"]),
                         once(cols["lfd"]), once(cols["lfd_paper"]), once(cols["promp_cma"])])
    return _block(table(["task", "case", "unit", "default model to expert", "paper's CNMP to expert",
                         "conditioned ProMP to expert", "default succeeds at once", "paper's CNMP at once",
                         "ProMP + CMA-ES at once"], rows),
                  "Distances: root mean square over the steps of the distance between the trajectory each "
                  "method starts from and the expert's own at the test condition (Meta-World: the hand's "
                  "x, y, z; E1: the path of the extrapolated amplitude; E2: the held-out demonstration's "
                  "joints; Pusher: the scripted expert's joints), medians over the seeds.", source(r, "peers"))


@renderer("algorithm-summary")
def algorithm_summary() -> str:
    """One paragraph for docs/ALGORITHM.md: the default and the paper's method against the peers."""
    r = load("peers")
    d, p = peers_verdicts(r, "acnmp"), peers_verdicts(r, "acnmp_paper")
    once = [x for x in r["runs"] if x["method"] == "lfd"]
    return (f"*In the comparison of record ({len(r['config']['tasks'])} tasks, {len(d)} tasks and cases, "
            f"{len(r['config']['seeds'])} seeds), the default is at least as good as the best peer on "
            f"{sum(v['met'] for v in d)} of {len(d)}, the paper's method on {sum(v['met'] for v in p)}; the "
            f"default model's first trajectory succeeds at once in {sum(x['success'] for x in once)} of "
            f"{len(once)} runs. The per-task table: [experiments/peers.md](experiments/peers.md).*\n\n"
            + source(r, "peers"))


def _default_beside_paper(task: str) -> str:
    """An experiment page's block: on ``task`` of the comparison of record, the default method beside
    the paper's (LfD only and ACNMP of each), per case: successes, median episodes, per seed."""
    r = load("peers")
    rows = []
    for case in r["config"]["cases"]:
        for m in ("lfd", "acnmp", "lfd_paper", "acnmp_paper"):
            runs = _runs(r, task, case, m)
            if runs:
                rows.append([case, PEER_LABELS[m], f"{sum(x['success'] for x in runs)}/{len(runs)}",
                             _median_shown(_median_episodes(runs), max(x["budget"] for x in runs)),
                             ", ".join(x["shown"] for x in runs)])
    return _block(table(["case", "method", "success", "episodes (median)", "per seed (0, 1, ...)"], rows),
                  f"The comparison of record's runs on this task ([peers.md](peers.md), {len(r['config']['seeds'])} "
                  f"seeds, budget {_budget(r)} episodes): the default method (the linear path beside the CNMP, each "
                  "mean first; [ALGORITHM.md](../ALGORITHM.md)) beside the paper's.", source(r, "peers"))


def _register() -> None:
    from benchmarks.report_kit import renderers

    renderers(_default_beside_paper, {"e1-default": ("e1-viapoint",), "e2-default": ("e2-push",),
                                      "pusher-default": ("pusher",)})


_register()


@renderer("method-study")
def method_study() -> str:
    """The method study's ladder (benchmarks/studies/method/): per task and case, each candidate's
    successes and median episodes, the two ends from the comparison of record."""
    study, r = load("method_study"), load("peers")
    ladder = (("paper", r, "acnmp_paper"), ("linear", study, "linear"), ("linear_clip", study, "linear_clip"),
              ("default", r, "acnmp"))
    rows = []
    for task in r["config"]["tasks"]:
        for case in r["config"]["cases"]:
            cells = []
            for _, res, method in ladder:
                runs = _runs(res, task, case, method)
                cells.append(f"{sum(x['success'] for x in runs)}/{len(runs)}, "
                             f"{_median_shown(_median_episodes(runs), _budget(r))}" if runs else "-")
            if any(c != "-" for c in cells):
                rows.append([_short(task), case, *cells])
    return _block(table(["task", "case", *[name for name, _, _ in ladder]], rows),
                  "Successes of 5 seeds, median episodes to a first success (\"> B\": half of the seeds or more did "
                  f"not succeed within the budget B = {_budget(r)}).", source(study, "method_study"), source(r, "peers"))
