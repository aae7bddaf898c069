"""``acnmp experiment pusher``: Gymnasium's MuJoCo Pusher-v5 extrapolated beyond its demonstrations;
LfD only, ACNMP and ProMP + RL (the worked example of a Gymnasium environment as a robot)."""
from __future__ import annotations

from .common import (add_promp_budget_argument, add_run_arguments, add_size_arguments,
                     check_deployment_arguments, seed_list, sizes, with_deployment, write_outputs)

#: --quick: every method end to end on two seeds in about a minute
QUICK = dict(seeds=2, train_steps=1500, budget=100, promp_budget=150)


def add_arguments(p) -> None:
    """Add the ``pusher`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    add_size_arguments(p, seeds=10, train_steps=3000, budget=400, budget_help="ACNMP roll-out budget per position")
    add_promp_budget_argument(p, "position")
    add_run_arguments(p, quick=QUICK,
                      plot="write the final distances and roll-outs per seed (PNG)",
                      deployment="the roll-outs on pusher (MuJoCo) workers",
                      quiet="no per-run lines")


def run(args) -> int:
    """Run the Pusher example as asked by ``args`` and print a summary table; returns the exit code."""
    import torch

    from acnmp_core.experiments.pusher import ACNMP_BUDGET, PROMP_BUDGET, TRAIN_STEPS, plot_pusher, run_pusher

    check_deployment_arguments(args)
    q = QUICK if args.quick else {}
    train_steps, budget = sizes(args, q.get("train_steps", TRAIN_STEPS), q.get("budget", ACNMP_BUDGET))
    seeds = seed_list(args, q.get("seeds", 10))
    torch.set_num_threads(1)  # the CNMP is small; threads only contend with the simulator
    kwargs = dict(train_steps=train_steps, acnmp_budget=budget,
                  promp_budget=args.promp_budget or q.get("promp_budget", PROMP_BUDGET),
                  log=None if args.quiet else print)
    if args.distributed:
        from clients.distributed import remote_rollouts

        with remote_rollouts("pusher", "pusher_push", workers=args.workers, record=args.record, prefix="pusher",
                             progress=not args.quiet, secure=not args.insecure, namespace=args.namespace, config=args.config) as make:
            result = with_deployment(run_pusher(seeds, evaluator_factory=lambda method, seed: make(
                f"pusher-{method}-s{seed}", {}, method=method, seed=seed), **kwargs), make)
    else:
        result = run_pusher(seeds, **kwargs)
    print(f"Pusher-v5, {result['seeds']} seed(s), success: the object within {result['tolerance']} m of the goal, "
          f"{result['wall_time_s']:.1f} s")
    print(f"{'method':<10} {'success':>8} {'roll-outs (median)':>18} {'final distance (m, median)':>27}")
    for m, s in result["methods"].items():
        print(f"{m:<10} {100 * s['success_rate']:>7.0f}% {s['rollouts_median']:>18.0f} {s['final_error_median']:>27.3f}")
    ratio = result["rollout_ratio_promp_over_acnmp"]
    print(f"ProMP + RL / ACNMP roll-outs: {'- (a method succeeded in half of the seeds or fewer)' if ratio is None else f'{ratio:.2f}x'}")
    return write_outputs(result, args, plot_pusher)
