"""The ``acnmp`` command line.

Each sub-command lives in its own module under :mod:`clients.commands`; a module there exposes
``register(subparsers)`` which adds its parser and sets ``func`` to a callable taking the parsed
arguments and returning an exit code. Modules are discovered, so adding a command is adding a file.
"""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from clients import commands


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with every sub-command of :mod:`clients.commands` registered."""
    parser = argparse.ArgumentParser(
        prog="acnmp",
        description=(
            "Adaptive Conditional Neural Movement Primitives: learn movement skills from a few "
            "demonstrations, adapt them by reinforcement learning, run them as a zenoh service."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        module = importlib.import_module(f"{commands.__name__}.{info.name}")
        if hasattr(module, "register"):
            module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv`` (default: sys.argv[1:]), run the chosen command, return its exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 130
    except ValueError as exc:
        print(f"acnmp: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
