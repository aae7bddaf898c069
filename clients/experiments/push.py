"""``acnmp experiment push``: E2, ACNMP vs adaptive ProMP + RL, a 3-DoF arm pushing a cylinder."""
from __future__ import annotations

from services.transport.argtypes import int_at_least

from .common import (add_promp_budget_argument, add_run_arguments, add_seeds_argument,
                     check_deployment_arguments, recipe_line, recipe_of, seed_list, with_deployment, write_outputs)

#: --quick: enough to see both methods run end to end in about a minute.
QUICK = dict(train_steps=1500, acnmp_budget=60, promp_budget=150)
#: CNMP training steps without --quick or --train-steps.
TRAIN_STEPS = 3000


def add_arguments(p) -> None:
    """Add the ``push`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    add_seeds_argument(p, 3)
    p.add_argument("--setting", choices=("paper", "authors"), default="paper",
                   help="task setting: 'paper' (default) or 'authors' (the authors' targets, scaled to "
                        "our arm, and their dense tracking reward for ACNMP)")
    p.add_argument("--train-steps", type=int_at_least(1), default=None,
                   help=f"CNMP training steps (default {TRAIN_STEPS})")
    p.add_argument("--acnmp-budget", type=int_at_least(1), default=None,
                   help="ACNMP roll-out budget per target (default 300)")
    add_promp_budget_argument(p, "target")
    add_run_arguments(p, quick=QUICK, recipe=True,
                      plot="write learning curves like the paper's Fig. 5(b) (PNG)",
                      deployment="the roll-outs on planar3 PyBullet workers",
                      quiet="no per-run lines, no progress bars")


def run(args) -> int:
    """Run E2 as asked by ``args`` and print a summary table; returns the exit code."""
    import torch

    from acnmp_core.baselines.promp_rl import PrompRLConfig
    from acnmp_core.experiments.push import ACNMP_BUDGET, PROMP_DEFAULTS, adapt_settings, run_push, task_config
    from acnmp_core.tasks.push.settings import push_setting

    torch.set_num_threads(1)  # the CNMP is small; threads only contend with the simulator
    q = QUICK if args.quick else {}
    # an option given wins over --quick, --quick over the defaults (the parser refused values below 1)
    train_steps = args.train_steps or q.get("train_steps") or TRAIN_STEPS
    acnmp_budget = args.acnmp_budget or q.get("acnmp_budget") or ACNMP_BUDGET
    promp_budget = args.promp_budget or q.get("promp_budget") or PROMP_DEFAULTS["max_rollouts"]
    recipe = recipe_of(args)
    kwargs = dict(
        train_steps=train_steps,
        adapt_config=adapt_settings(recipe, acnmp_budget),
        recipe=recipe,
        promp_config=PrompRLConfig(**{**PROMP_DEFAULTS, "max_rollouts": promp_budget}),
        log=None if args.quiet else print,
        setting=push_setting(args.setting),
    )
    check_deployment_arguments(args)
    if args.distributed and args.setting != "paper":
        raise ValueError("--distributed: the workers run the paper setting only; drop --setting authors")
    if args.distributed:
        from clients.distributed import remote_rollouts

        with remote_rollouts("planar3", "push", workers=args.workers, record=args.record, prefix="e2",
                             progress=not args.quiet, secure=not args.insecure, namespace=args.namespace, config=args.config) as make:
            result = with_deployment(run_push(seed_list(args, 3), evaluator_factory=lambda setup, method, case: make(
                f"push-{method}-{case}", task_config(setup, method), method=method), **kwargs), make)
    else:
        result = run_push(seed_list(args, 3), **kwargs)
    print(f"E2 push ({result['setting']} setting, {recipe_line(result)}), {result['seeds']} seed(s), "
          f"tolerance {result['tolerance']} m, {result['wall_time_s']:.1f} s")
    print(f"{'method':<9} {'case':<14} {'roll-outs (median)':>18} {'success':>8} {'error (m)':>10} {'initial (m)':>11}")
    for m, cases in result["methods"].items():
        for c, s in cases.items():
            print(f"{m:<9} {c:<14} {s['rollouts_median']:>18.0f} {100 * s['success_rate']:>7.0f}% "
                  f"{s['final_error_median']:>10.4f} {s['lfd_error_median']:>11.4f}")
    for c, ratio in result["rollout_ratio_promp_over_acnmp"].items():
        print(f"ProMP+RL / ACNMP roll-outs ({c}): {'-' if ratio is None else f'{ratio:.2f}x'}")
    from acnmp_core.experiments.plots import plot_push

    return write_outputs(result, args, plot_push)
