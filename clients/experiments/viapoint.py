"""``acnmp experiment viapoint``: E1, LfD-only vs RL-only vs ACNMP on an extrapolated via-point."""
from __future__ import annotations

import contextlib
import sys

import numpy as np

from services.transport.argtypes import int_at_least

from .common import (add_run_arguments, add_seeds_argument, check_deployment_arguments, recipe_line, recipe_of,
                     seed_list, write_json)


def add_arguments(p) -> None:
    """Add the ``viapoint`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    add_seeds_argument(p, 1, "seeds of training and exploration, one run each", old="--seed")
    p.add_argument("--variant", choices=("2d", "1d"), default="2d",
                   help="2d paths around obstacles (default) or the authors' 1-D two-bump function")
    p.add_argument("--budget", type=int_at_least(1), default=100, help="roll-out budget per method (default 100)")
    p.add_argument("--train-steps", type=int_at_least(1), default=3000,
                   help="supervised training steps (default 3000)")
    p.add_argument("--fresh", action="store_true",
                   help="with --distributed: always start a fresh deployment, even when one is running")
    add_run_arguments(p, recipe=True, plot="write Fig. 3-like PNG (and FILE_latents.png like Fig. 4)",
                      deployment="training and adaptation jobs on the learner, roll-outs on point2d workers",
                      quiet="no progress bars")


def run(args) -> int:
    """Run E1 as asked by ``args`` (each seed in turn) and print a summary table per seed; returns
    the exit code. One seed's JSON is its summary; several seeds' holds each one's (``runs``) and
    the aggregates over them (:func:`~acnmp_core.experiments.viapoint.summarise_seeds`)."""
    import torch

    from acnmp_core.experiments.viapoint import run_viapoint, summarise_seeds

    # One intra-op thread: the learner's jobs run with one too, and float reductions then happen
    # in the same order, so the in-process and the distributed runs give the same numbers.
    torch.set_num_threads(1)

    seeds = seed_list(args, 1)
    kwargs = dict(variant=args.variant, budget=args.budget, train_steps=args.train_steps, progress=not args.quiet,
                  recipe=recipe_of(args))
    check_deployment_arguments(args)
    if args.fresh and not args.distributed:
        raise ValueError("--fresh: only with --distributed")
    if args.namespace is not None and args.fresh:
        raise ValueError("--namespace and --fresh: choose a running deployment or a fresh one")
    runs = []
    if args.distributed:
        from clients.distributed import e1_deployment, run_viapoint_on

        with _running_deployment(args) as client, \
                e1_deployment(workers=args.workers, record=args.record, secure=not args.insecure,
                              progress=not args.quiet, client=client) as (deployed, facts):
            for seed in seeds:
                runs.append(run_viapoint_on(deployed, facts, seed, **kwargs))
                _print_run(runs[-1].summary)
    else:
        for seed in seeds:
            runs.append(run_viapoint(seed, **kwargs))
            _print_run(runs[-1].summary)
    if len(runs) == 1:
        write_json(runs[0].summary, args.json)
    else:
        summaries = [r.summary for r in runs]
        agg = summarise_seeds(summaries)
        print(f"over seeds {', '.join(map(str, seeds))}: " + "; ".join(
            f"{m} {100 * r['success_rate']:.0f}% succeed, median {r['rollouts_median']:.0f} roll-outs"
            for m, r in agg["methods"].items()))
        write_json({"experiment": "viapoint", "recipe": kwargs["recipe"].to_dict(), "seeds": len(seeds), "seed_list": seeds,
                    **agg, "runs": summaries}, args.json)
    if args.plot:
        from acnmp_core.experiments.plots import plot_viapoint

        for p in plot_viapoint(runs[0], args.plot):  # the first seed's
            print(f"wrote {p}")
    sys.stdout.flush()
    return 0


def _print_run(s: dict) -> None:
    """One seed's table (a summary of :func:`~acnmp_core.experiments.viapoint.run_viapoint`)."""
    tol = ", ".join(f"{x:.4f}" for x in np.ravel(s["tolerance"]))
    print(f"E1 via-point ({s['variant']}), seed {s['seed']}, {recipe_line(s)}, tolerance (start, via-point, end) {tol}, "
          f"{s['wall_time_s']:.1f} s")
    print(f"{'method':<10} {'roll-outs':>9} {'success':>8} {'error':>8} {'via err':>8} {'end err':>8} {'shape err':>10}")
    for m, r in s["methods"].items():
        print(f"{m:<10} {r['rollouts']:>9} {str(r['success']):>8} {r['error']:>8.4f} {r['viapoint_error']:>8.4f} "
              f"{r['endpoint_error']:>8.4f} {r['shape_error']:>10.4f}")
    a = s["assimilation"]
    if a.get("performed"):
        print(f"assimilation: solved with no RL {a['success_after']} (error {a['error_after']:.4f}), old demos "
              f"RMSE {a['old_demos_reproduction_rmse_before']:.4f} -> {a['old_demos_reproduction_rmse_after']:.4f}")
    sk = s.get("skill")
    if sk is not None:
        print(f"skill {sk['name']}: " + (f"version {sk['version']} trained for this run" if sk["trained"] else
                                          f"version {sk['version']} used as it was (already trained from these "
                                          "demonstrations with these settings)"), flush=True)


@contextlib.contextmanager
def _running_deployment(args):
    """An operator client of the running deployment ``--distributed`` uses (``--namespace``, reached
    through ``--config`` when given, or the one `acnmp up` runs), or None for a fresh deployment
    (``--fresh``, or none running). ValueError when ``--namespace`` names none, or ``--record`` asks
    a running one to record."""
    from clients.distributed import operator_client
    from services.transport.runfile import DeploymentNotFound, find

    if args.fresh:
        yield None
        return
    namespace = args.namespace
    if namespace is None:
        try:
            namespace = find(None).namespace
        except DeploymentNotFound:
            yield None
            return
    if args.record:
        raise ValueError(f"--record: deployment {namespace!r} is running; its recorder (acnmp up --record) "
                         "records, or use --fresh")
    if args.insecure:
        raise ValueError(f"--insecure: deployment {namespace!r} is running and keeps its own authentication; "
                         "use --fresh to start an unauthenticated one")
    with operator_client(namespace, args.config) as client:
        where = f"through {args.config}" if args.config else "found by its run file"
        print(f"running E1 on deployment {client.namespace!r} ({where}); --fresh starts a new one", flush=True)
        yield client
