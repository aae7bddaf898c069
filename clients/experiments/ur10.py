"""``acnmp experiment ur10``: E5, a UR10 picks and places over an obstacle, extrapolated to taller
objects and obstacles; LfD only vs ACNMP, per-joint errors against the expert."""
from __future__ import annotations

from .common import (add_run_arguments, add_size_arguments, check_deployment_arguments, recipe_line, recipe_of,
                     seed_list, sizes, with_deployment, write_outputs)


def add_arguments(p) -> None:
    """Add the ``ur10`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    add_size_arguments(p, seeds=5, train_steps=10000, budget=60, budget_help="ACNMP roll-out budget per case")
    p.add_argument("--cases", default=None, metavar="8_10,9_11",
                   help="comma-separated test cases, object_obstacle heights in cm (default: 8_10,9_11,10_12)")
    add_run_arguments(p, recipe=True, plot="write the per-joint trajectories of the first seed (PNG)",
                      deployment="the roll-outs on ur10 PyBullet workers",
                      quiet="no per-run lines")


def run(args) -> int:
    """Run E5 as asked by ``args`` and print a summary table; returns the exit code."""
    import torch

    from acnmp_core.experiments.ur10 import BUDGET, CASES, TRAIN_STEPS, adapt_settings, plot_ur10, run_ur10

    cases = tuple(CASES) if args.cases is None else tuple(c.strip() for c in args.cases.split(",") if c.strip())
    unknown = [c for c in cases if c not in CASES]
    if unknown or not cases:
        raise ValueError(f"--cases: expected a comma-separated subset of {','.join(CASES)}, got {args.cases!r}")
    train_steps, budget = sizes(args, TRAIN_STEPS, BUDGET)
    check_deployment_arguments(args)
    torch.set_num_threads(1)  # the CNMP is small; threads only contend with the simulator
    recipe = recipe_of(args)
    kwargs = dict(train_steps=train_steps, adapt_config=adapt_settings(recipe, budget), cases=cases,
                  log=None if args.quiet else print, recipe=recipe)
    if args.distributed:
        from clients.distributed import remote_rollouts

        with remote_rollouts("ur10", "pick_place", workers=args.workers, record=args.record, prefix="e5",
                             progress=not args.quiet, secure=not args.insecure, namespace=args.namespace, config=args.config) as make:
            result = with_deployment(run_ur10(seed_list(args, 5), evaluator_factory=lambda case: make(
                f"ur10-{case}", {}, method="acnmp"), **kwargs), make)
    else:
        result = run_ur10(seed_list(args, 5), **kwargs)
    print(f"E5 UR10, {recipe_line(result)}, {result['seeds']} seed(s), {result['wall_time_s']:.1f} s; joint errors "
          f"(deg, median over seeds) "
          f"{', '.join(result['joint_names'])}")
    print(f"{'case':<6} {'method':<9} {'success':>8} {'roll-outs':>9}  joint errors (deg)")
    for case, methods in result["cases"].items():
        for m, s in methods.items():
            errs = " ".join(f"{e:6.2f}" for e in s["joint_error_deg"])
            print(f"{case:<6} {m:<9} {100 * s['success_rate']:>7.0f}% {s['rollouts_median']:>9.0f}  {errs}")
    return write_outputs(result, args, plot_ur10)
