"""E3: assimilation, first-training and stopping-criterion candidates side by side on ``run_wall``.

Each candidate is a set of ``run_wall`` keyword arguments (steps, episodes per step, targets per
episode, learning rate, anchor weight), and optionally the adaptations' stopping criterion
(``stop_tolerance``, ``stop_clearance``: the paper setting with its ``goal_tolerance`` and
``goal_clearance`` replaced; the trigger, and with it the test success, stays the setting's 0.25
criterion); the rest are the library's defaults. ACNMP only unless ``--methods`` names more (the
ProMP + RL baseline with the same stopping criterion, for a fair comparison). Candidates run in
processes, at most two at once (the machine is shared), on the same environments and seed; every
variant keeps its own provenance, so candidates may be run in several invocations and merged into
one file (``--merge`` into ``--out`` as it runs, or ``--combine`` files of earlier invocations without
running anything). ``--recipe default`` runs ACNMP as the product's default method instead of the
paper's (acnmp_core/experiments/recipe.py; every variant records its recipe, and files of two recipes
are not merged). Writes ``benchmarks/studies/e3_wall/results/e3_budget.json`` (``e3_budget_default.json``
with ``--recipe default``). Usage:
``python benchmarks/experiments/e3_budget.py [--envs 300] [--seed 0] [--candidates NAME ...] [--methods M ...] [--merge]
[--recipe paper|default] [--out FILE]``,
``python benchmarks/experiments/e3_budget.py --combine A.json B.json ... [--out FILE]``,
``python benchmarks/experiments/e3_budget.py --combine-seeds S0.json S1.json ... --out FILE`` (several seeds).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from acnmp_core.experiments.recipe import Recipe  # noqa: E402
from acnmp_core.experiments.wall import ALL_METHODS, TRAIN_DEFAULTS, run_wall  # noqa: E402
from acnmp_core.tasks.wall.settings import PAPER, WallSetting  # noqa: E402
from benchmarks._results import provenance, save_result, study_results  # noqa: E402
from clients.experiments.common import add_run_arguments, output_path, recipe_of  # noqa: E402

#: name -> run_wall keyword arguments that differ from the defaults ("baseline": none).
CANDIDATES = {
    "baseline": {},
    "a100x128x30_lr1e-3": dict(assimilate_steps=100, assimilate_batch_size=128, assimilate_targets=30,
                               assimilate_lr=1e-3),
    "a100x128x30_lr3e-4": dict(assimilate_steps=100, assimilate_batch_size=128, assimilate_targets=30,
                               assimilate_lr=3e-4),
    # The anchor conditions on the goal at t = 1 but teaches the solution's end, which an adaptation
    # leaves up to the 0.25 tolerance away from it: does the skill learn to miss from it?
    "anchor0": dict(assimilate_anchor_weight=0.0),
    # The anchor is the only term shaped like a test query (start at t = 0, goal at t = 1): weight it more.
    "anchor3": dict(assimilate_anchor_weight=3.0),
    "anchor3_s150": dict(assimilate_anchor_weight=3.0, assimilate_steps=150),
    # A more precise first skill (e3_fit_precision: 46 % instead of 38 % from the 30 demonstrations).
    "first3000x128x30": dict(batch_size=128, n_targets=30),
    # Less forgetting per assimilation.
    "lr1e-4": dict(assimilate_lr=1e-4),
    # Hysteresis, as the authors: adaptations triggered at 0.25 stop only on a stricter criterion, so
    # the skill assimilates precise solutions rather than ones just inside the 0.25 tolerance.
    "stop0.10_c0.05": dict(stop_tolerance=0.10, stop_clearance=0.05),
    "stop0.15_c0": dict(stop_tolerance=0.15, stop_clearance=0.0),
    # After the first pair: which of the two (tolerance, clearance) cost stop0.10_c0.05 its test success,
    # and a milder hysteresis.
    "stop0.10_c0": dict(stop_tolerance=0.10, stop_clearance=0.0),
    "stop0.20_c0": dict(stop_tolerance=0.20, stop_clearance=0.0),
    # Assimilation's optimiser: one Adam kept over the skill's life instead of a fresh one per
    # solution (whose first steps move every weight by about the full rate), and/or a rate that
    # decays to a tenth within each assimilation.
    # The defaults before e3_optimizer.json (the "baseline" of the runs before it).
    "fresh_opt": dict(keep_optimizer=False, assimilate_lr_final=None),
    "keep_opt": dict(keep_optimizer=True),
    "cos3e-5": dict(assimilate_lr_final=3e-5),
    "keep_opt_cos3e-5": dict(keep_optimizer=True, assimilate_lr_final=3e-5),  # the defaults since
    # With the optimiser kept, a higher rate per solution no longer restarts Adam's moments; or half
    # the steps, for time.
    "keep_opt_1e-3_cos1e-4": dict(keep_optimizer=True, assimilate_lr=1e-3, assimilate_lr_final=1e-4),
    "keep_opt_cos3e-5_s150": dict(keep_optimizer=True, assimilate_lr_final=3e-5, assimilate_steps=150),
    # After keep_opt_1e-3_cos1e-4 led: is it the rate or the decay, and does a lower end help?
    "keep_opt_1e-3": dict(keep_optimizer=True, assimilate_lr=1e-3),
    "keep_opt_1e-3_cos1e-5": dict(keep_optimizer=True, assimilate_lr=1e-3, assimilate_lr_final=1e-5),
    # From the new defaults (keep_opt_cos3e-5): twice the steps per solution, or a higher first rate.
    "keep_opt_cos3e-5_s600": dict(keep_optimizer=True, assimilate_lr_final=3e-5, assimilate_steps=600),
    "keep_opt_1e-3_cos3e-5": dict(keep_optimizer=True, assimilate_lr=1e-3, assimilate_lr_final=3e-5),
    # Solutions moved onto their own start and goal before assimilation (executed first, counted):
    # an adaptation stops within 0.25 of the goal, and the skill learnt to miss by as much.
    "snap": dict(snap_solutions=True),
    # What the end points still cost (run with --methods acnmp promp_rl; measurements, not the paper's
    # method): every method's generated paths moved onto start and goal before they are executed or
    # scored; and every executed path too, the adaptations' roll-outs included.
    "snap_outputs": dict(snap_outputs=True),
    "snap_outputs_rollouts": dict(snap_outputs=True, snap_rollouts=True),
    # With snapped solutions (the defaults since e3_snap.json): does half the assimilation budget
    # (the largest share of the run's time) keep the test success?
    "snap_s150": dict(snap_solutions=True, assimilate_steps=150),
    # The anchor (the solution given its own start and goal) now teaches exact ends: weight it more.
    "snap_anchor3": dict(snap_solutions=True, assimilate_anchor_weight=3.0),
    # The supervised steps also target the episodes' observations (as conditional neural processes
    # do), so the skill learns to pass through the start and goal it is conditioned on.
    "targets_obs": dict(targets_include_obs=True),
    # After the stream, more supervised steps on everything the skill has (e3_fit_precision: the
    # CNMP's end points sharpen with training budget; once at the end costs far less than per solution).
    "consolidate5k": dict(consolidate_steps=5000),
    "consolidate10k": dict(consolidate_steps=10000),
    # At the default with the boundary conditions enforced (issue 37), ACNMP's time per seed misses
    # 120 s and the assimilation is half of it: does a half or a third of its steps keep the targets?
    "ends_s150": dict(assimilate_steps=150),
    "ends_s100": dict(assimilate_steps=100),
}
#: Candidate keys that set the stopping criterion rather than a run_wall argument.
STOP_KEYS = ("stop_tolerance", "stop_clearance")


def candidate_setting(overrides: dict) -> WallSetting:
    """The paper setting with a candidate's stopping criterion (start/goal errors <= ``stop_tolerance``
    and clearance > ``stop_clearance``, world units); the paper setting itself when it sets neither."""
    return replace(PAPER, goal_tolerance=overrides.get("stop_tolerance", PAPER.goal_tolerance),
                   goal_clearance=overrides.get("stop_clearance", PAPER.goal_clearance))


def _one(name: str, envs: int, seed: int, eval_every: int, methods: tuple[str, ...], recipe: Recipe) -> dict:
    """One E3 run of candidate ``name`` with ``methods``, ACNMP's method ``recipe``; returns ACNMP's
    summary and curve (when it ran), the other methods' under ``others``, the config, the recipe and
    the provenance."""
    torch.set_num_threads(1)
    meta = provenance()
    kw = {k: v for k, v in CANDIDATES[name].items() if k not in STOP_KEYS}
    r = run_wall(envs, seed, eval_every=eval_every, methods=methods, setting=candidate_setting(CANDIDATES[name]),
                 recipe=recipe, **kw)
    out = {"provenance": meta, "overrides": CANDIDATES[name], "methods": list(methods), "recipe": r["recipe"]}
    if "acnmp" in methods:
        out.update(summary=r["methods"]["acnmp"], curve=r["curves"]["acnmp"])
    others = {m: {"summary": r["methods"][m], "curve": r["curves"][m]} for m in methods if m != "acnmp"}
    return {**out, **({"others": others} if others else {}), "config": r["config"], "wall_time_s": r["wall_time_s"]}


def _read_results(files: list[str]) -> list[dict]:
    """The earlier results to merge, read from ``files``; a missing or unreadable file ends the run
    with a one-line message."""
    try:
        return [json.loads(Path(f).read_text()) for f in files]
    except (OSError, json.JSONDecodeError) as e:
        sys.exit(f"e3_budget.py: cannot read an earlier result: {e}")


def _recipe(parts: list[dict], option: str) -> dict:
    """The one recipe of ``parts``' variants (the paper's for variants run before it was recorded);
    ends the run naming ``option`` when they ran two."""
    recipes = {json.dumps(v.get("recipe", Recipe("paper").to_dict()), sort_keys=True)
               for p in parts for v in (p.get("variants") or {}).values()}
    if len(recipes) > 1:
        sys.exit(f"{option}: the variants ran different recipes ({', '.join(sorted(recipes))}); keep them apart")
    return json.loads(recipes.pop()) if recipes else Recipe("paper").to_dict()


def _combine(files: list[str], out: str, meta: dict) -> int:
    """Merge the variants of earlier e3_budget results (same envs and seed; each variant keeps its
    own provenance) into ``out``; the run time is the sum of theirs (they ran one after the other)."""
    parts = _read_results(files)
    recipe = _recipe(parts, "--combine")
    if len({(p["envs"], p["seed"]) for p in parts}) != 1:
        sys.exit(f"--combine: the files differ in envs or seed: {files}")
    variants = {n: v for p in parts for n, v in p["variants"].items()}
    return save_result({"provenance": meta, "experiment": "e3_budget", "envs": parts[0]["envs"], "seed": parts[0]["seed"],
                 "recipe": recipe,
                 "defaults": TRAIN_DEFAULTS, "variants": variants, "combined_from": [p["provenance"] for p in parts],
                 "wall_time_s": round(sum(p["wall_time_s"] for p in parts), 2)}, out)


def _combine_seeds(files: list[str], out: str, meta: dict) -> int:
    """Merge e3_budget results of the same envs but different seeds into ``out``:
    ``{"seeds": {seed: {variant: ...}}}``; a variant named twice for one seed is refused."""
    parts = _read_results(files)
    recipe = _recipe(parts, "--combine-seeds")
    if len({p["envs"] for p in parts}) != 1:
        sys.exit(f"--combine-seeds: the files differ in envs: {files}")
    seeds: dict[str, dict] = {}
    for p in parts:
        mine = seeds.setdefault(str(p["seed"]), {})
        twice = set(mine) & set(p["variants"])
        if twice:
            sys.exit(f"--combine-seeds: seed {p['seed']} has {sorted(twice)} twice")
        mine.update(p["variants"])
    return save_result({"provenance": meta, "experiment": "e3_budget_seeds", "envs": parts[0]["envs"],
                 "recipe": recipe, "defaults": TRAIN_DEFAULTS, "seeds": seeds, "combined_from": [p["provenance"] for p in parts],
                 "wall_time_s": round(sum(p["wall_time_s"] for p in parts), 2)}, out)


def main(argv: list[str] | None = None) -> int:
    """Run the chosen candidates (two at a time) and write, or merge into, the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_arguments(ap, seed=0, envs=300, eval_every=60)
    ap.add_argument("--candidates", nargs="+", default=list(CANDIDATES), choices=list(CANDIDATES), metavar="NAME",
                    help=f"the candidates to run, among {', '.join(CANDIDATES)} (default: all)")
    ap.add_argument("--methods", nargs="+", default=["acnmp"], choices=list(ALL_METHODS),
                    help="the methods each candidate runs (default ACNMP only)")
    ap.add_argument("--merge", action="store_true", help="keep the variants already in --out")
    ap.add_argument("--combine", nargs="+", metavar="JSON", help="only merge these earlier results into --out")
    ap.add_argument("--combine-seeds", nargs="+", metavar="JSON",
                    help="only merge earlier results of several seeds (same envs) into --out")
    add_run_arguments(ap, recipe=True, out=study_results("e3_wall") / "e3_budget.json")
    args = ap.parse_args(argv)
    out, recipe = output_path(args), recipe_of(args)
    meta = provenance()
    if args.combine:
        return _combine(args.combine, out, meta)
    if args.combine_seeds:
        return _combine_seeds(args.combine_seeds, out, meta)
    old = json.loads(Path(out).read_text()) if args.merge and Path(out).exists() else {}
    if old and (old["envs"], old["seed"]) != (args.envs, args.seed):
        ap.error(f"--merge: {out} holds envs {old['envs']}, seed {old['seed']}")
    if old and _recipe([old], "--merge") != recipe.to_dict():
        ap.error(f"--merge: {out} holds variants of another recipe than --recipe {recipe.name}")
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        futures = {n: pool.submit(_one, n, args.envs, args.seed, args.eval_every, tuple(args.methods), recipe)
                   for n in args.candidates}
        variants = {n: f.result() for n, f in futures.items()}
    for n, r in variants.items():
        runs = {**({"acnmp": r["summary"]} if "summary" in r else {}),
                **{m: o["summary"] for m, o in r.get("others", {}).items()}}
        for m, s in runs.items():
            print(f"{n:<16} {m:<9} test success {100 * s['test_success_rate']:.1f} %  error {s['test_error_mean']:.3f}  "
                  f"goal error {s['test_goal_error_mean']:.3f}  trajectories {s['trajectories_total']}  "
                  f"max {s['trajectories_per_env_max']}  adaptations {s['adaptations']}  {s['time_s']:.0f} s")
    result = {"provenance": meta, "experiment": "e3_budget", "envs": args.envs, "seed": args.seed,
              "recipe": recipe.to_dict(), "defaults": TRAIN_DEFAULTS, "variants": {**old.get("variants", {}), **variants},
              "wall_time_s": round(time.perf_counter() - t0, 2)}
    return save_result(result, out)


if __name__ == "__main__":
    sys.exit(main())
