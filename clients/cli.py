"""The ``acnmp`` command line.

Each sub-command lives in its own module under :mod:`clients.commands`; a module there exposes
``register(subparsers)`` which adds its parser and sets ``func`` to a callable taking the parsed
arguments and returning an exit code. Modules are discovered, so adding a command is adding a file.
"""
from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import pkgutil
import signal
import sys
import threading

from clients import commands
from services.transport.argtypes import Parser, UsageError


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived while a command ran: it unwinds like Ctrl-C (context managers stop what they
    started, a local deployment included) and the process then exits normally, so its exit handlers
    run too (e.g. the removal of the generated URDF files), which SIGTERM's default action skips."""


@contextlib.contextmanager
def sigterm_unwinds():
    """While inside, SIGTERM raises :class:`Terminated` in the main thread, unless a handler other than
    the default is in place (a command that handles it itself, e.g. ``acnmp up``, installs its own
    inside, which wins); the previous handler is restored on the way out."""
    if threading.current_thread() is not threading.main_thread() \
            or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        yield
        return

    def handler(signum, frame):
        raise Terminated()

    signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def build_parser() -> argparse.ArgumentParser:
    """Return the top-level parser with every sub-command of :mod:`clients.commands` registered."""
    parser = Parser(
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


#: Set to 1 to see the traceback of an unexpected error instead of its one-line summary.
TRACEBACK_ENV = "ACNMP_TRACEBACK"
#: Exit code after the reader of our output went away (``acnmp replay FILE | head``): 128 + SIGPIPE.
BROKEN_PIPE = 141


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv`` (default: sys.argv[1:]), run the chosen command, return its exit code.

    Every failure is one line on stderr and a nonzero exit: 2 for a bad argument (ValueError, and
    argparse's own errors), 1 for a failure at run time (no connection, an unreadable file, an
    unexpected error: its type and message; ``ACNMP_TRACEBACK=1`` shows the traceback), 130 for
    Ctrl-C, 143 for SIGTERM (both unwind what the command started, see :class:`Terminated`), 141
    when stdout is a pipe whose reader has gone (quietly: ``| head`` is not an error).
    ``--help`` prints the help and raises SystemExit(0), as argparse does.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:
        return exc.code
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        with sigterm_unwinds():
            code = int(args.func(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, not at interpreter exit
        return code
    except Terminated:
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # nobody reads stdout any more; point it at /dev/null so the exit-time flush is quiet too
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return BROKEN_PIPE
    except ValueError as exc:
        print(f"acnmp: error: {exc}", file=sys.stderr)
        return 2
    except ConnectionError as exc:
        print(f"acnmp: {exc} (is a router listening there? for a deployment of `acnmp up`, leave out "
              f"--connect: its run file gives the anchor and the credentials)", file=sys.stderr)
        return 1
    except OSError as exc:  # a file that cannot be read or written
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"acnmp: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 1
    except Exception as exc:  # never a traceback for a user; the type says where to look
        if os.environ.get(TRACEBACK_ENV) == "1":
            raise
        first = str(exc).splitlines()[0] if str(exc) else ""
        print(f"acnmp: error: {type(exc).__name__}: {first} (set {TRACEBACK_ENV}=1 for the traceback)",
              file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
