"""``acnmp experiment <name>``: run one of the paper's experiments (modules in clients.experiments)."""
from __future__ import annotations

import functools
import importlib
import pkgutil

from clients import experiments
from clients.experiments.common import check_output_arguments


def register(subparsers) -> None:
    """Add ``experiment`` with one sub-command per module of :mod:`clients.experiments`."""
    parser = subparsers.add_parser(
        "experiment",
        help="reproduce one of the paper's experiments (E1 viapoint, E2 push, E3 wall, E4 transfer, E5 ur10, E6 pour)",
        description="Reproduce one of the paper's experiments in simulation; --json and --plot save results.",
    )
    sub = parser.add_subparsers(dest="experiment", metavar="NAME", required=True)
    for info in sorted(pkgutil.iter_modules(experiments.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{experiments.__name__}.{info.name}")
        if hasattr(module, "register"):
            module.register(sub)
    for parser_ in sub.choices.values():  # every experiment checks where it will write before it runs
        run = parser_.get_default("func")
        if run is not None:
            parser_.set_defaults(func=functools.partial(_checked, run))


def _checked(run, args) -> int:
    """Check the output options of ``args`` (ValueError naming the option), then ``run(args)``."""
    check_output_arguments(args)
    return run(args)
