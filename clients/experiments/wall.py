"""``acnmp experiment wall``: E3, self-improvement over wall-with-a-hole environments, ACNMP vs ProMP + RL
(and the baseline after Ewerton et al. 2019), in the paper's or the authors' task setting."""
from __future__ import annotations

import numpy as np

from services.transport.argtypes import int_at_least

from .common import (add_run_arguments, apply_threads, check_deployment_arguments, recipe_line, recipe_of, seed_list,
                     with_deployment, write_json)


def add_arguments(p) -> None:
    """Add the ``wall`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    add_run_arguments(p, seeds=1, seeds_what="seeds of environments, training and exploration, one run each",
                      old_seeds="--seed", envs=100, eval_every=10)
    p.add_argument("--initial", type=int_at_least(1), default=30, help="demonstrated environments (default 30)")
    p.add_argument("--test", type=int_at_least(1), default=1000, help="test environments (default 1000)")
    p.add_argument("--assimilate-from", choices=("skill", "adapted"), default=None,
                   help="ACNMP's assimilation continues from the skill before the adaptation, or from the "
                        "adapted copy (default: run_wall's, the skill)")
    p.add_argument("--setting", default="paper",
                   help="task setting: 'paper' (default; wall 0.2 x hole 1.0, tolerance 0.25) or 'authors' "
                        "(their notebook: wall 2 x hole 2, RL when an error > 0.15 or the squared clearance "
                        "< 0.2, until errors < 0.05 and squared clearance > 0.4)")
    p.add_argument("--methods", default="acnmp,promp_rl",
                   help="comma-separated methods: acnmp, promp_rl (ProMP + REPS), ewerton (ProMP + PRO + GP "
                        "after Ewerton et al. 2019); default acnmp,promp_rl")
    p.add_argument("--solutions-as-found", action="store_true",
                   help="assimilate ACNMP's solutions as the adaptation found them, not moved onto their start "
                        "and goal first (the default moves, executes and keeps the moved path if it succeeds)")
    p.add_argument("--snap-paths", choices=("none", "generated", "all"), default="generated",
                   help="move paths onto the start and goal they were conditioned on before they are executed "
                        "or scored, for every method alike: 'generated' (the default, \"boundary conditions "
                        "enforced\": the paths for new and test environments), 'none' (the paper's variant: "
                        "paths as generated) or 'all' (the adaptations' roll-outs too)")
    add_run_arguments(p, threads=True, recipe=True,
                      plot="write test error / success vs environments and trajectories (PNG)",
                      deployment="the roll-outs on point2d workers",
                      quiet="no progress lines")


def run(args) -> int:
    """Run E3 as asked by ``args`` (each seed in turn), print the curve and a summary per seed;
    returns the exit code. One seed's JSON is its result; several seeds' holds each one's (``runs``)."""
    from acnmp_core.tasks.wall.settings import wall_setting

    # The arguments are checked before torch is imported, so a mistake is reported at once.
    try:
        setting = wall_setting(args.setting)
    except ValueError as exc:
        raise ValueError(f"--{exc}") from None
    methods = tuple(m.strip() for m in args.methods.split(",") if m.strip())
    from acnmp_core.experiments.wall import ALL_METHODS

    bad = [m for m in methods if m not in ALL_METHODS]
    if bad or not methods:
        raise ValueError(f"--methods: expected a comma-separated subset of {', '.join(ALL_METHODS)}, got {args.methods!r}")
    if args.distributed and setting.name != "paper":
        raise ValueError("--setting authors: runs in-process only (the point2d workers score the paper's wall)")
    from acnmp_core.experiments.wall import run_wall

    apply_threads(args)
    kwargs = dict(n_initial=args.initial, n_test=args.test, eval_every=args.eval_every, setting=setting,
                  methods=methods,
                  **({} if args.assimilate_from is None else {"assimilate_from": args.assimilate_from}),
                  **({"snap_solutions": False} if args.solutions_as_found else {}),
                  snap_outputs=args.snap_paths != "none", snap_rollouts=args.snap_paths == "all",
                  log=None if args.quiet else (lambda s: print(s, flush=True)), recipe=recipe_of(args))
    check_deployment_arguments(args)
    seeds = seed_list(args, 1)
    results = []
    if args.distributed:
        from clients.distributed import remote_rollouts

        with remote_rollouts("point2d", "wall", workers=args.workers, record=args.record, prefix="e3",
                             progress=not args.quiet, secure=not args.insecure, namespace=args.namespace, config=args.config) as make:
            for seed in seeds:
                results.append(with_deployment(run_wall(args.envs, seed, evaluator_factory=lambda method: make(
                    f"wall-{method}", method=method, seed=seed), **kwargs), make))
                _print_run(results[-1], args.snap_paths)
    else:
        for seed in seeds:
            results.append(run_wall(args.envs, seed, **kwargs))
            _print_run(results[-1], args.snap_paths)
    if len(results) == 1:
        write_json(results[0], args.json)
    else:
        print(f"over seeds {', '.join(map(str, seeds))}: " + "; ".join(
            f"{m} mean test success {100 * np.mean([r['methods'][m]['test_success_rate'] for r in results]):.1f}%"
            for m in results[0]["methods"]))
        write_json({"experiment": "wall", "recipe": kwargs["recipe"].to_dict(), "seeds": len(seeds), "seed_list": seeds,
                    "runs": results}, args.json)
    if args.plot:
        from acnmp_core.experiments.plots import plot_wall

        print(f"wrote {plot_wall(results[0], args.plot)}", flush=True)  # the first seed's
    return 0


def _print_run(result: dict, snap_paths: str) -> None:
    """One seed's summary table (a result of :func:`~acnmp_core.experiments.wall.run_wall`)."""
    snapped = {"none": "paths as generated (the paper's variant)", "generated": "boundary conditions enforced",
               "all": "every executed path snapped"}[snap_paths]
    print(f"E3 wall ({result['setting']} setting, {snapped}, {recipe_line(result)}), seed {result['seed']}, {result['n_initial']} demonstrated + "
          f"{result['envs']} new environments, {result['n_test']} test, {result['wall_time_s']:.1f} s")
    print(f"{'method':<9} {'test success':>12} {'test error':>10} {'trajectories':>12} {'max/env':>8} "
          f"{'median/env':>10} {'paper-style':>11}")
    for m, s in result["methods"].items():
        print(f"{m:<9} {100 * s['test_success_rate']:>11.1f}% {s['test_error_mean']:>10.3f} "
              f"{s['trajectories_total']:>12} {s['trajectories_per_env_max']:>8} {s['trajectories_per_env_median']:>10.0f} "
              f"{s['trajectories_paper_style']:>11}")
    print("paper-style = environments x the per-environment maximum, as the paper counts its totals")
    ratio = result["trajectory_ratio_promp_over_acnmp"]
    if ratio is not None:
        print(f"ProMP+RL / ACNMP trajectories: {ratio:.2f}x", flush=True)
