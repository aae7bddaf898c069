"""``acnmp experiment transfer``: E4, a 3-DoF arm's skill transferred to a 4-DoF arm and refined by RL."""
from __future__ import annotations

from pathlib import Path

from services.transport.argtypes import int_at_least

from .common import (add_run_arguments, add_seeds_argument, check_deployment_arguments, recipe_line, recipe_of,
                     seed_list, write_outputs)


def add_arguments(p) -> None:
    """Add the ``transfer`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    add_seeds_argument(p, 30, "runs' seeds", old="--runs")
    p.add_argument("--pair-steps", type=int_at_least(1), default=None,
                   help="training steps of each transfer pair on our task (default 6000)")
    p.add_argument("--budget", type=int_at_least(1), default=None,
                   help="roll-outs per RL run in robot B, 2 per iteration (default 40)")
    p.add_argument("--no-authors-data", action="store_true",
                   help="skip the check on the authors' published arrays")
    p.add_argument("--authors-data", metavar="DIR", default=None,
                   help="directory of the authors' E4 arrays (3doftraining_joint_trajectories.npy, ...; "
                        "default: ../shared/data/acnmp-paper/experiment4 beside the repository)")
    add_run_arguments(p, recipe=True, plot="write success vs RL iteration per condition, the paper's beside (PNG)",
                      deployment="the pairs trained by the learner, the 4-DoF arm's first attempt from the model "
                                "service's transfer query, its roll-outs on planar4 PyBullet workers",
                      quiet="no per-run lines")


def run(args) -> int:
    """Run E4 as asked by ``args`` and print a summary table; returns the exit code."""
    import torch

    from dataclasses import replace

    from acnmp_core.experiments.transfer import AUTHORS_DATA, TransferExperimentConfig, load_authors_data, run_transfer

    torch.set_num_threads(1)  # the CNMPs are small; threads only contend with the simulator
    check_deployment_arguments(args)
    data_dir = AUTHORS_DATA if args.authors_data is None else Path(args.authors_data)
    if args.authors_data is not None and not args.no_authors_data and load_authors_data(data_dir) is None:
        raise ValueError(f"--authors-data {args.authors_data}: the authors' four E4 arrays are not all there")
    cfg = TransferExperimentConfig(recipe=recipe_of(args))
    if args.pair_steps is not None:
        cfg.pair = replace(cfg.pair, steps=args.pair_steps)
    if args.budget is not None:
        cfg.adapt = replace(cfg.adapt, max_rollouts=args.budget)
    kwargs = dict(cfg=cfg, authors_data=not args.no_authors_data, authors_data_dir=data_dir,
                  log=None if args.quiet else (lambda s: print(s, flush=True)))
    if args.distributed:
        from clients.transfer_service import run_transfer_distributed

        result = run_transfer_distributed(seed_list(args, 30), workers=args.workers, record=args.record,
                                          progress=not args.quiet, secure=not args.insecure,
                                          namespace=args.namespace, config=args.config, **kwargs)
        diffs = [r["first_attempt_diff"] for r in result["per_run"] if r.get("first_attempt_diff") is not None]
        print(f"pairs trained by the learner ({len(result['pair_jobs'])} train_pair jobs); robot B's first "
              f"attempt from the model service's transfer query, largest difference from the RL's start "
              f"{max(diffs) if diffs else 0.0:.3g} rad")
    else:
        result = run_transfer(seed_list(args, 30), **kwargs)
    print(f"E4 transfer 3-DoF -> 4-DoF, {recipe_line(result)}, {result['runs']} run(s), {result['wall_time_s']:.1f} s")
    print(f"{'condition':<13} " + " ".join(f"{'after ' + k:>9}" for k in result["paper"]["success_by_iteration"])
          + f" {'iterations (median)':>20} {'initial error (m)':>18}")
    paper = result["paper"]["success_by_iteration"]
    print(f"{'paper':<13} " + " ".join(f"{100 * v:>8.0f}%" for v in paper.values()))
    for cond, s in result["conditions"].items():
        med = "-" if s["iterations_median"] is None else f"{s['iterations_median']:.0f}"
        print(f"{cond:<13} " + " ".join(f"{'not run':>9}" if s['success_by_iteration'][k] is None
                                         else f"{100 * s['success_by_iteration'][k]:>8.0f}%" for k in paper)
              + f" {med:>20} {s['initial_error_median']:>18.4f}")
    a = result["authors_data"]
    if a:
        print(f"authors' data, RMSE (rad) against the 4-DoF ground truth: transfer {a['transfer_rmse']:.3f}, "
              f"mean demonstration {a['mean_demo_rmse']:.3f}, nearest demonstration's partner "
              f"{a['nearest_partner_rmse']:.3f}")
    elif not args.no_authors_data:
        print(f"authors' data check skipped: their arrays are not in {data_dir} (--authors-data DIR)")
    from acnmp_core.experiments.plots import plot_transfer

    return write_outputs(result, args, plot_transfer)
