"""``acnmp up``: start a whole local deployment (recorder, learner, model, workers) with no configuration."""
from __future__ import annotations

import sys


def register(subparsers) -> None:
    """Add the ``up`` sub-command."""
    from acnmp_core.robots.registry import robot_kinds

    p = subparsers.add_parser("up", help="start a local deployment on 127.0.0.1 until Ctrl-C / SIGTERM",
                              description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("--namespace", "-n", default="default", help="key prefix acnmp/<namespace>/ (default: %(default)s)")
    p.add_argument("--workers", type=int, default=2, help="number of workers (default: %(default)s)")
    p.add_argument("--robot", default=robot_kinds()[0], choices=robot_kinds(),
                   help="robot kind of the workers (default: %(default)s)")
    p.add_argument("--record", default=None, metavar="FILE.rrd", help="start a recorder writing this file")
    p.add_argument("--state-dir", default=None, metavar="DIR",
                   help="learner checkpoints and process logs, locked while the deployment runs "
                        "(default: runs/<namespace>/state)")
    p.add_argument("--no-model", action="store_true", help="do not start the model service")
    p.add_argument("--demos", action="append", default=[], metavar="SKILL=FILE.npz",
                   help="have the learner train SKILL from a demonstration file at start (repeatable)")
    p.set_defaults(func=run)


def run(args) -> int:
    """Start the deployment, print what runs where, wait for SIGINT/SIGTERM (restarting children that
    die meanwhile, see services/launcher/supervision.py), stop everything; exit 0."""
    from services.launcher import LocalDeployment
    from services.learner.store import StateDirInUse
    from services.transport import install_shutdown_handlers

    stop = install_shutdown_handlers()
    learner_args = [a for spec in args.demos for a in ("--demos", spec)]
    state_dir = args.state_dir or f"runs/{args.namespace}/state"
    dep = LocalDeployment(args.namespace, args.workers, args.robot, record=args.record, state_dir=state_dir,
                          model=not args.no_model, learner_args=learner_args, report=report)
    try:
        try:
            dep.start()
        except StateDirInUse as exc:  # nothing was started
            print(f"acnmp up: {exc}", file=sys.stderr)
            return 1
        print(dep.describe(), flush=True)
        print("deployment is up; Ctrl-C or SIGTERM stops it", flush=True)
        while not stop.wait(0.5):  # the deployment's supervisor restarts (and reports) dead children
            pass
    finally:
        codes = dep.stop()
    bad = {n: c for n, c in codes.items() if c != 0}
    if bad:
        print(f"acnmp up: processes ended with errors: {bad}", file=sys.stderr)
    print("deployment stopped: " + " ".join(f"{n}={c}" for n, c in codes.items()), flush=True)
    return 0


def report(line: str) -> None:
    """One line of the supervisor (a child restarted, live again, given up) on stderr."""
    print(f"acnmp up: {line}", file=sys.stderr, flush=True)
