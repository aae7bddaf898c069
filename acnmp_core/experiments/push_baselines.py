"""E2 against the baselines of Stark et al. 2019 ("Experience reuse with probabilistic movement
primitives", IROS 2019), in one run, one simulator and one task setting.

Methods (:data:`METHODS`), all on the same targets, with the same budget per target, the same
roll-out accounting (every executed trajectory counts, the mean's too) and the same success
criterion (the cylinder's final distance to the target at most the tolerance):

* ``acnmp``: as in :mod:`~acnmp_core.experiments.push` (LfD roll-out, then adaptation).
* ``promp_scratch``: ProMP + episodic REPS with weighted maximum likelihood, from no experience: the
  mean holds the start posture, isotropic prior std :data:`SCRATCH_STD` rad per weight.
* ``promp_similar``: the same RL from the demonstrated skill whose effect (the cylinder's final
  position when the demonstration is executed) is nearest the target.
* ``promp_mixture``: the same RL from a similarity-weighted mixture of the demonstrated skills.
* ``promp_tuned``: the project's tuned variant (nearest skill by task parameters, CMA-style
  covariance update), as ``promp_rl`` in :mod:`~acnmp_core.experiments.push`.

The Stark-style settings (:data:`STARK`) are guesses where the paper is not at hand: see
benchmarks/studies/e2_push/README.md, "Baselines after Stark et al.".
"""
from __future__ import annotations

import copy
import time
from dataclasses import replace
from typing import Callable

from ..adaptation.config import AdaptConfig
from ..baselines.promp_rl import PrompRLConfig
from ..tasks.push.settings import PAPER, PushSetting
from .push import (CASES, PROMP_DEFAULTS, _plain, _summarise, demo_effects, make_setup, make_task, record_run,
                   run_acnmp_case, run_promp_case, train_push_cnmp)

#: Prior std (rad per ProMP weight) of the from-scratch baseline: broad against the demos' spread.
SCRATCH_STD = 0.3
#: Stark-style REPS: KL bound, samples per iteration, weighted-ML covariance, the initial skill's
#: covariance the demos' weight covariance times ``init_cov_scale`` (as the tuned variant's).
STARK = dict(method="reps", epsilon=0.5, n_samples=20, cov_update="wml", init_cov_scale=0.1, min_std=0.01)
#: ProMP configuration per baseline (the budget and seed are set per run).
BASELINES: dict[str, PrompRLConfig] = {
    "promp_scratch": PrompRLConfig(**STARK, init="scratch", scratch_std=SCRATCH_STD),
    "promp_similar": PrompRLConfig(**STARK, init="similar"),
    "promp_mixture": PrompRLConfig(**STARK, init="mixture"),
    "promp_tuned": PrompRLConfig(**PROMP_DEFAULTS),
}
METHODS = ("acnmp", *BASELINES)
#: Roll-out budget per target, for every method (the tuned ProMP baseline's in E2).
BUDGET = PROMP_DEFAULTS["max_rollouts"]


def run_push_baselines(
    seeds: int | list[int] = 10,
    *,
    setting: PushSetting = PAPER,
    budget: int = BUDGET,
    train_steps: int = 3000,
    methods: tuple[str, ...] = METHODS,
    cases: tuple[str, ...] = CASES,
    log: Callable[[str], None] | None = None,
    on_seed: Callable[[dict], None] | None = None,
    demo_path: str | None = None,
) -> dict:
    """Run every method of ``methods`` on ``cases`` over ``seeds`` in ``setting``.

    seeds : a count N (seeds 0..N-1) or a list; each seeds CNMP training, exploration and sampling.
    budget : roll-outs per target for every method (ACNMP's ``max_rollouts`` too).
    train_steps : CNMP training steps. log : called with one line per finished run.
    on_seed : called after each seed with the result over the seeds finished so far (a run that is
        stopped keeps what it measured).
    demo_path : the setting's demonstration file (default: its generated cache).

    Returns the JSON-ready ``{"setting", "seeds", "seed_list", "budget", "tolerance", "targets"
    {case: [x, y]}, "wall_time_s", "methods" {method: {case: {rollouts_median, rollouts,
    success_rate, final_error_median, lfd_error_median, lfd_success_rate}}}, "config", "runs"}``.
    """
    seed_list = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    if not seed_list:
        raise ValueError("seeds: expected at least one seed")
    unknown = [m for m in methods if m not in METHODS] + [c for c in cases if c not in CASES]
    if unknown:
        raise ValueError(f"methods/cases: unknown {unknown}; expected {METHODS} and {CASES}")
    if budget < 3:
        raise ValueError(f"budget: expected at least 3 roll-outs, got {budget}")
    t0 = time.perf_counter()
    setup = make_setup(demo_path, setting=setting)
    effects = demo_effects(setup)
    acfg = AdaptConfig.paper(max_rollouts=budget)
    tasks = {}
    runs: list[dict] = []

    def result(done: list[int]) -> dict:
        summary = {m: {c: _summarise([r for r in runs if r["method"] == m and r["case"] == c]) for c in cases}
                   for m in methods}
        return {
            "setting": setting.name,
            "seeds": len(done),
            "seed_list": done,
            "budget": budget,
            "tolerance": setup.tolerance,
            "targets": {c: setup.targets[c].tolist() for c in CASES},
            "wall_time_s": round(time.perf_counter() - t0, 2),
            "methods": summary,
            "config": {"train_steps": train_steps, "acnmp": _plain(vars(acfg)), "setting": _plain(vars(setting)),
                       **{m: _plain(vars(replace(BASELINES[m], max_rollouts=budget))) for m in methods
                          if m != "acnmp"}},
            "runs": list(runs),
        }

    try:
        for seed in seed_list:
            model = train_push_cnmp(setup.demos, seed, train_steps) if "acnmp" in methods else None
            for method in methods:
                for case in cases:
                    if (method == "acnmp", case) not in tasks:
                        tasks[(method == "acnmp", case)] = make_task(setup, method, case)
                    ev = tasks[(method == "acnmp", case)]
                    t1 = time.perf_counter()
                    if method == "acnmp":
                        r = run_acnmp_case(copy.deepcopy(model), setup, case, ev, acfg, seed)
                    else:
                        cfg = replace(BASELINES[method], max_rollouts=budget, seed=seed)
                        r = run_promp_case(setup, case, ev, cfg, effects=effects)
                    record_run(runs, r, seed, method, case, t1, log, prefix=f"{setting.name} ", width=13)
            if on_seed:
                on_seed(result(seed_list[:seed_list.index(seed) + 1]))
    finally:
        for task in tasks.values():
            task.close()
    return result(seed_list)
