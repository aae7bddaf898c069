"""``acnmp experiment robot``: your robot and demonstrations: LfD only against ACNMP at task
parameters you name (any registered robot kind or plugin)."""
from __future__ import annotations

from services.transport.argtypes import non_empty, robot_kind

from .common import (add_run_arguments, add_size_arguments, check_deployment_arguments, seed_list, sizes,
                     with_deployment, write_outputs)


def _point(text: str) -> list[float]:
    import argparse
    import math

    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected finite numbers, got {text!r}")
    return values


def add_arguments(p) -> None:
    """Add the ``robot`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    p.add_argument("--robot", required=True, type=robot_kind, help="robot kind or plugin package.module:attr")
    p.add_argument("--task", default=None, help="the robot's task (default: its only one)")
    import argparse
    import textwrap

    from acnmp_core.data.demo_io import format_help

    p.formatter_class = argparse.RawDescriptionHelpFormatter  # the epilog's table keeps its lines
    p.description = textwrap.fill(p.description or "", 90)
    p.epilog = format_help()
    p.add_argument("--demos", required=True, type=non_empty, metavar="FILE.npz",
                   help="the demonstrations: arrays times (N, T), values (N, T, D), task_params (N, P) (below)")
    p.add_argument("--at", action="append", required=True, type=_point, metavar="P1,P2,...",
                   help="task parameters of a test point (repeatable)")
    add_size_arguments(p, seeds=1, train_steps=3000, budget=300, budget_help="ACNMP roll-out budget per point")
    add_run_arguments(p, plot="write the remaining errors and ACNMP's roll-outs per point (PNG)",
                      deployment="the roll-outs on workers of the robot",
                      quiet="no per-run lines")


def run(args) -> int:
    """Run it as asked by ``args`` and print one row per method; returns the exit code."""
    import torch

    from acnmp_core.data.demo_io import load_demos
    from acnmp_core.experiments.own_robot import check_points, plot_own_robot, robot_task, run_own_robot

    check_deployment_arguments(args)
    demos = load_demos(args.demos)
    check_points(demos, args.at, "--at")
    task = robot_task(args.robot, args.task)
    train_steps, budget = sizes(args, 3000, 300)
    torch.set_num_threads(1)
    kwargs = dict(task=task, seeds=seed_list(args, 1), train_steps=train_steps, budget=budget,
                  log=None if args.quiet else print)
    if args.distributed:
        from clients.distributed import remote_rollouts

        with remote_rollouts(args.robot, task, workers=args.workers, record=args.record, prefix="robot",
                             progress=not args.quiet, secure=not args.insecure, namespace=args.namespace, config=args.config) as make:
            result = with_deployment(run_own_robot(args.robot, demos, args.at, evaluator_factory=lambda m, s, i: make(
                f"{args.robot}-{m}-s{s}-p{i}", {}, method=m, seed=s), **kwargs), make)
    else:
        result = run_own_robot(args.robot, demos, args.at, **kwargs)
    print(f"robot {result['robot']}, task {result['task']}, {len(result['points'])} point(s) x {result['seeds']} "
          f"seed(s), {result['wall_time_s']:.1f} s")
    print(f"{'method':<8} {'success':>8} {'roll-outs (median)':>18} {'error (median)':>15}")
    for m, s in result["methods"].items():
        print(f"{m:<8} {100 * s['success_rate']:>7.0f}% {s['rollouts_median']:>18.0f} {s['final_error_median']:>15.4f}")
    return write_outputs(result, args, plot_own_robot)
