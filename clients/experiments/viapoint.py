"""``acnmp experiment viapoint``: E1, LfD-only vs RL-only vs ACNMP on an extrapolated via-point."""
from __future__ import annotations

import contextlib
import sys

import numpy as np

from services.transport.argtypes import int_at_least

from .common import add_deployment_arguments, add_output_arguments, check_deployment_arguments, write_json


def add_arguments(p) -> None:
    """Add the ``viapoint`` experiment's options to its parser ``p`` (made from its catalog entry)."""
    p.add_argument("--seed", type=int_at_least(0), default=0, help="seed of training and exploration (default 0)")
    p.add_argument("--variant", choices=("2d", "1d"), default="2d",
                   help="2d paths around obstacles (default) or the authors' 1-D two-bump function")
    p.add_argument("--budget", type=int_at_least(1), default=100, help="roll-out budget per method (default 100)")
    p.add_argument("--train-steps", type=int_at_least(1), default=3000,
                   help="supervised training steps (default 3000)")
    add_output_arguments(p, "write Fig. 3-like PNG (and FILE_latents.png like Fig. 4)")
    add_deployment_arguments(p, "training and adaptation jobs on the learner, roll-outs on point2d workers")
    p.add_argument("--fresh", action="store_true",
                   help="with --distributed: always start a fresh deployment, even when one is running")
    p.add_argument("--quiet", action="store_true", help="no progress bars")


def run(args) -> int:
    """Run E1 as asked by ``args`` and print a summary table; returns the exit code."""
    import torch

    from acnmp_core.experiments.viapoint import run_viapoint

    # One intra-op thread: the learner's jobs run with one too, and float reductions then happen
    # in the same order, so the in-process and the distributed runs give the same numbers.
    torch.set_num_threads(1)

    kwargs = dict(seed=args.seed, variant=args.variant, budget=args.budget, train_steps=args.train_steps,
                  progress=not args.quiet)
    check_deployment_arguments(args)
    if args.fresh and not args.distributed:
        raise ValueError("--fresh: only with --distributed")
    if args.namespace is not None and args.fresh:
        raise ValueError("--namespace and --fresh: choose a running deployment or a fresh one")
    if args.distributed:
        from clients.distributed import run_viapoint_distributed

        with _running_deployment(args) as client:
            result = run_viapoint_distributed(workers=args.workers, record=args.record, client=client,
                                              secure=not args.insecure, **kwargs)
    else:
        result = run_viapoint(**kwargs)
    s = result.summary
    tol = ", ".join(f"{x:.4f}" for x in np.ravel(s["tolerance"]))
    print(f"E1 via-point ({s['variant']}), seed {s['seed']}, tolerance (start, via-point, end) {tol}, "
          f"{s['wall_time_s']:.1f} s")
    print(f"{'method':<10} {'roll-outs':>9} {'success':>8} {'error':>8} {'via err':>8} {'end err':>8} {'shape err':>10}")
    for m, r in s["methods"].items():
        print(f"{m:<10} {r['rollouts']:>9} {str(r['success']):>8} {r['error']:>8.4f} {r['viapoint_error']:>8.4f} "
              f"{r['endpoint_error']:>8.4f} {r['shape_error']:>10.4f}")
    a = s["assimilation"]
    if a.get("performed"):
        print(f"assimilation: solved with no RL {a['success_after']} (error {a['error_after']:.4f}), old demos "
              f"RMSE {a['old_demos_reproduction_rmse_before']:.4f} -> {a['old_demos_reproduction_rmse_after']:.4f}")
    write_json(s, args.json)
    if args.plot:
        from acnmp_core.plots import plot_viapoint

        for p in plot_viapoint(result, args.plot):
            print(f"wrote {p}")
    sys.stdout.flush()
    return 0


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
