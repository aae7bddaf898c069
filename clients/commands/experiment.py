"""``acnmp experiment <name>``: run one of the experiments :data:`clients.experiments.catalog.CATALOG`
declares (their options and runs in the modules of clients.experiments)."""
from __future__ import annotations

import contextlib
import functools
import importlib
import signal
import sys
import threading

from clients.experiments.catalog import CATALOG
from clients.experiments.common import check_output_arguments


def register(subparsers) -> None:
    """Add ``experiment`` with one sub-command per entry of the catalog, in its order."""
    parser = subparsers.add_parser(
        "experiment",
        help="reproduce one of the paper's experiments ("
             + ", ".join(f"{e.ident} {e.name}" for e in CATALOG if e.ident and not e.optional) + "), or run your robot's",
        description="Reproduce one of the paper's experiments in simulation; --json and --plot save results.",
    )
    sub = parser.add_subparsers(dest="experiment", metavar="NAME", required=True)
    for entry in CATALOG:
        p = sub.add_parser(entry.name, help=entry.help, description=entry.description)
        module = importlib.import_module(entry.module)
        module.add_arguments(p)
        # every experiment checks where it will write before it runs
        p.set_defaults(func=functools.partial(_checked, module.run))


def _checked(run, args) -> int:
    """Check the output options of ``args`` (ValueError naming the option), then ``run(args)``;
    a Ctrl-C or SIGTERM meanwhile first prints :func:`interrupted_line` (then unwinds as before)."""
    check_output_arguments(args)
    with say_when_interrupted(interrupted_line(args)):
        return run(args)


def interrupted_line(args) -> str:
    """The line an interrupted ``acnmp experiment`` prints at once: what it stops, what is kept."""
    stops = ("stopping the run and the local deployment it started (a running one it joined keeps running)"
             if getattr(args, "distributed", False) else "stopping the run")
    kept = []
    if getattr(args, "record", None):
        kept.append(f"the recording {args.record} keeps the roll-outs so far")
    unwritten = [f"--{name} {getattr(args, name)}" for name in ("json", "plot") if getattr(args, name, None)]
    if unwritten:
        kept.append(f"{' and '.join(unwritten)} not written (results are written at the end)")
    return f"acnmp experiment {args.experiment}: interrupted; {stops}; {'; '.join(kept) or 'nothing is saved'}"


@contextlib.contextmanager
def say_when_interrupted(line: str):
    """While inside, SIGINT and SIGTERM first print ``line`` on stderr, then do what they did
    before (KeyboardInterrupt; :class:`clients.cli.Terminated`); a second signal is not announced
    again. Only in the main thread (elsewhere a no-op); the handlers are restored on the way out."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    previous = {sig: prev for sig, prev in previous.items() if prev not in (signal.SIG_IGN, None)}

    def handler(signum, frame):
        for sig, prev in previous.items():  # once: a second Ctrl-C acts as it always did
            signal.signal(sig, prev)
        print(line, file=sys.stderr, flush=True)
        prev = previous[signum]
        if callable(prev):
            prev(signum, frame)
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        signal.raise_signal(signum)  # SIGTERM's default action, as without this handler

    for sig in previous:
        signal.signal(sig, handler)
    try:
        yield
    finally:
        for sig, prev in previous.items():
            signal.signal(sig, prev)
