"""``acnmp experiment pour``: E6, pour 1322 g from a 1400 g cup (outside the demonstrations);
LfD only vs ACNMP, then the assimilated solution."""
from __future__ import annotations

from services.transport.argtypes import int_at_least

from .common import (add_run_arguments, add_size_arguments, check_deployment_arguments, recipe_line, recipe_of,
                     seed_list, sizes, with_deployment, write_outputs)


def add_arguments(p) -> None:
    """Add the ``pour`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    add_size_arguments(p, seeds=5, train_steps=3000, budget=60, budget_help="ACNMP roll-out budget")
    p.add_argument("--no-assimilation", action="store_true", help="skip the assimilation and its checks")
    p.add_argument("--assimilate-from", choices=("skill", "adapted"), default=None,
                   help="assimilate the solution into the model as it was before the adaptation, or into "
                        "the adapted model (default: run_pour's, the skill)")
    p.add_argument("--jobs", type=int_at_least(1, 64), default=1,
                   help="seeds run in this many processes at once, same result (not with --distributed; default 1)")
    add_run_arguments(p, recipe=True, plot="write the error of every roll-out per seed (PNG)",
                      deployment="the roll-outs on pour PyBullet workers",
                      quiet="no per-seed lines")


def run(args) -> int:
    """Run E6 as asked by ``args`` and print a summary; returns the exit code."""
    import torch

    from acnmp_core.experiments.pour import BUDGET, TOLERANCE_G, TRAIN_STEPS, e6_adapt_config, plot_pour, run_pour

    train_steps, budget = sizes(args, TRAIN_STEPS, BUDGET)
    check_deployment_arguments(args)
    if args.jobs > 1 and args.distributed:
        raise ValueError("--jobs: expected 1 with --distributed")
    torch.set_num_threads(1)  # the CNMP is small; threads only contend with the simulator
    recipe = recipe_of(args)
    kwargs = dict(train_steps=train_steps, adapt_config=e6_adapt_config(budget, recipe), recipe=recipe,
                  assimilate_solution=not args.no_assimilation, log=None if args.quiet else print,
                  **({} if args.assimilate_from is None else {"assimilate_from": args.assimilate_from}))
    if args.distributed:
        from clients.distributed import remote_rollouts

        with remote_rollouts("pour", "pour", workers=args.workers, record=args.record, prefix="e6",
                             progress=not args.quiet, secure=not args.insecure, namespace=args.namespace, config=args.config) as make:
            result = with_deployment(run_pour(seed_list(args, 5), evaluator_factory=lambda: make(
                "pour", {"tolerance_g": TOLERANCE_G}, method="acnmp"), **kwargs), make)
    else:
        result = run_pour(seed_list(args, 5), jobs=args.jobs, **kwargs)
    a, s = result["acnmp"], result["assimilation"]
    print(f"E6 pour {result['test']['target_g']:.0f} g from {result['test']['weight_g']:.0f} g, {recipe_line(result)}, "
          f"{result['seeds']} seed(s), {result['wall_time_s']:.1f} s")
    print(f"LfD only: error {result['lfd_only']['error_g']:.0f} g (median)")
    print(f"ACNMP: success {100 * a['success_rate']:.0f}% ({100 * a['success_within_20_rate']:.0f}% within 20 "
          f"roll-outs), roll-outs {a['rollouts_median']:.0f} (median), final error {a['final_error_g_median']:.0f} g; "
          f"final mean within 30 g one roll-out after the budget: {a['solved_after_budget']} seed(s); first roll-out "
          f"within 30 g per seed: {a['first_success_rollout']}")
    if s["seeds_assimilated"]:
        print(f"assimilated ({s['seeds_assimilated']} seed(s)): no-RL error {s['error_g_no_rl']:.0f} g, "
              f"demonstrations within 30 g {s['demos_reproduced_within_30g']:.0f}/16 (medians)")
    if result["rollout_cpu_s_median"] is not None:
        print(f"CPU per roll-out: {result['rollout_cpu_s_median']:.2f} s (median)")
    return write_outputs(result, args, plot_pour)
