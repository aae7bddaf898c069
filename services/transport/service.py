"""One way to run any service: a config dataclass, its command line, its process lifetime.

A service is a :class:`Service` subclass: a dataclass whose fields are its options (declared with
:func:`option`, which also gives their ``--help``), plus ``session`` (the zenoh options every
process shares) and a :meth:`Service.serve` method that runs on an open session until a stop event
is set. Everything else is done here, once for every service:

* :func:`add_arguments` builds the ``acnmp serve <name>`` parser from the fields,
  :func:`from_args` builds the config back from the parsed arguments;
* :func:`run_service` installs the SIGTERM/SIGINT handlers (and the launcher watch), opens the
  session, declares the process's ``about`` queryable (its host, pid and ready line;
  services/transport/about.py), calls ``serve`` and closes the session whatever happens;
* :func:`main` is the ``python -m services.<wing>`` entry point of each wing's ``__main__.py``.

Example (the worker's)::

    @dataclass
    class WorkerConfig(Service):
        name: ClassVar[str] = "worker"
        summary: ClassVar[str] = "a roll-out worker of one robot kind"
        robot: str = option("point2d", "robot kind", type=robot_kind)
        worker_id: str | None = option(None, "worker id (default: <robot>-<pid>)", flag="--id")

        def serve(self, session, stop, ready) -> int: ...
"""
from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
import threading
import types
import typing
from dataclasses import dataclass, field
from typing import Any, Callable, ClassVar, Sequence

import zenoh

from .argtypes import Parser, UsageError
from .lifetime import install_shutdown_handlers
from .session import MODES, SessionOptions

class Ready:
    """What :meth:`Service.serve` is handed to say how it is: ``ready(line)`` once, when live, with
    one line saying what it serves (its ``about`` reply's ``live``); ``ready.report_health(check)``
    at any time, where ``check()`` returns one line per problem the process has now (its ``about``
    reply's ``problems``, which ``acnmp status`` shows; services/transport/about.py).

    ``say`` gets the ready line (default: printed); ``about`` is the process's about queryable
    (None: nothing is published, e.g. a service run by a test without a session).
    """

    def __init__(self, say: Callable[[str], None] | None = None, about=None):
        self._say = say or (lambda line: print(line, flush=True))
        self._about = about

    def __call__(self, line: str) -> None:
        if self._about is not None:
            self._about.live = line
        self._say(line)

    def report_health(self, check: Callable[[], list[str]]) -> None:
        """Answer ``check()`` as this process's problems from now on."""
        if self._about is not None:
            self._about.health = check


def option(default: Any, help: str, *, flag: str | None = None, short: str | None = None,
           metavar: str | None = None, choices: Sequence[str] | Callable[[], Sequence[str]] | None = None,
           type: Callable[[str], Any] | None = None) -> Any:
    """A :class:`Service` field that is also a command-line option.

    ``default`` (a list default is copied per instance), ``help`` (``%(default)s`` allowed),
    ``flag`` (default ``--<field-name>`` with ``-`` for ``_``), ``short`` (e.g. ``-o``),
    ``metavar``, ``choices`` (a sequence, or a function returning one, called when the parser is
    built), ``type`` (the argparse type, e.g. a bounded one of :mod:`services.transport.argtypes`;
    default: the field's annotation). A ``list[...]`` field becomes a repeatable option.
    """
    meta = {"help": help, "flag": flag, "short": short, "metavar": metavar, "choices": choices, "type": type}
    if isinstance(default, list):
        return field(default_factory=lambda: list(default), metadata=meta)
    return field(default=default, metadata=meta)


@dataclass
class Service:
    """Base of every service's config; see the module docstring.

    Class attributes: ``name`` (``acnmp serve <name>``, log prefix), ``summary`` (one line of help),
    ``default_mode`` (zenoh mode when neither ``--mode`` nor ``--config`` says), ``modes`` (the
    modes it accepts).
    """

    name: ClassVar[str] = "service"
    summary: ClassVar[str] = ""
    default_mode: ClassVar[str] = "peer"
    modes: ClassVar[tuple[str, ...]] = MODES

    session: SessionOptions = field(default_factory=SessionOptions, metadata={"cli": False})

    def serve(self, session: zenoh.Session, stop: threading.Event, ready: Ready) -> int:
        """Run on the open ``session`` until ``stop`` is set, calling ``ready`` once live; return
        the exit code. Closing the session is not its job."""
        raise NotImplementedError

    def prepare(self) -> None:
        """What a process running this service does first, while it has no zenoh session and no
        thread of its own (:func:`run_process`; not when a service runs on a thread of another
        program): e.g. fork helper processes. Nothing by default."""


def _option_fields(cls: type[Service]):
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if f.metadata.get("cli", True) and "help" in f.metadata:
            yield f, hints[f.name]


def _scalar_type(hint) -> tuple[type, bool]:
    """(element type, repeatable) of a field annotation: ``int``, ``float | None``, ``list[str]``..."""
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        return _scalar_type(args[0])
    if origin is list:
        return typing.get_args(hint)[0], True
    return hint, False


def add_arguments(parser: argparse.ArgumentParser, cls: type[Service], only: Sequence[str] | None = None) -> None:
    """Add ``cls``'s options and the shared session options to ``parser`` (a parser or an argument
    group); with ``only`` (field names), just those options, without the session options: a
    launcher's command line that hands them on to its ``cls`` child (:func:`handed_on`)."""
    for f, hint in _option_fields(cls):
        if only is not None and f.name not in only:
            continue
        meta = f.metadata
        kind, repeat = _scalar_type(hint)
        flags = [meta["flag"] or "--" + f.name.replace("_", "-")] + ([meta["short"]] if meta["short"] else [])
        kwargs: dict[str, Any] = {"dest": f.name, "help": meta["help"], "metavar": meta["metavar"]}
        default = f.default_factory() if f.default_factory is not dataclasses.MISSING else f.default
        if kind is bool:
            kwargs.update(action="store_true", default=default)
            kwargs.pop("metavar")
        else:
            kwargs.update(type=meta["type"] or kind, default=default)
            if repeat:
                kwargs["action"] = "append"
        choices = meta["choices"]
        if choices is not None:
            kwargs["choices"] = tuple(choices() if callable(choices) else choices)
        parser.add_argument(*flags, **kwargs)
    if only is None:
        SessionOptions.add_arguments(parser, default_mode=cls.default_mode, modes=cls.modes)


def handed_on(cls: type[Service], args: argparse.Namespace, only: Sequence[str]) -> list[str]:
    """The command line of ``cls``'s options ``only`` (added by :func:`add_arguments` with ``only``)
    whose parsed value in ``args`` is not the default, e.g. ``["--keep-jobs", "50"]``: what a
    launcher passes its ``cls`` child. Scalar options only."""
    argv = []
    for f, _ in _option_fields(cls):
        value = getattr(args, f.name, f.default)
        if f.name in only and value != f.default:
            argv += [f.metadata["flag"] or "--" + f.name.replace("_", "-"), str(value)]
    return argv


def from_args(cls: type[Service], args: argparse.Namespace) -> Service:
    """The config of ``cls`` from arguments parsed by a parser built with :func:`add_arguments`."""
    values = {f.name: getattr(args, f.name) for f, _ in _option_fields(cls)}
    return cls(session=SessionOptions.from_args(args), **values)


def run_service(config: Service, *, stop: threading.Event | None = None,
                ready: Callable[[str], None] | None = None) -> int:
    """Run the service ``config`` describes until ``stop`` is set (default: SIGTERM/SIGINT, or its
    launcher dying); return its exit code. ``ready(line)`` gets the ready line (default: printed)."""
    from .about import AboutQueryable
    from .auth import forget_secrets_when_launcher_dies
    from .keys import Keyspace

    forget_secrets_when_launcher_dies(config.session.config)  # before the launcher is watched
    if stop is None:
        stop = install_shutdown_handlers()
    with config.session.open(config.default_mode) as session:
        about = AboutQueryable(session, Keyspace(config.session.namespace), config.name)
        try:
            return int(config.serve(session, stop, Ready(ready, about)) or 0)
        finally:
            about.undeclare()


def run_process(config: Service) -> int:
    """Run ``config`` as the whole of this process (``python -m services.<wing>``, ``acnmp serve``):
    :meth:`Service.prepare`, then :func:`run_service`; returns the exit code."""
    config.prepare()
    return run_service(config)


def parser_for(cls: type[Service], prog: str | None = None) -> argparse.ArgumentParser:
    """A stand-alone parser for ``cls`` (what ``python -m services.<wing>`` uses)."""
    parser = Parser(prog=prog or f"acnmp serve {cls.name}", description=cls.summary)
    add_arguments(parser, cls)
    return parser


def configure_logging(name: str) -> None:
    """Log lines prefixed with the process name (one format for every service)."""
    logging.basicConfig(level=logging.INFO, format=f"%(asctime)s {name} %(levelname)s %(message)s")


def main(cls: type[Service], argv: list[str] | None = None) -> int:
    """Parse ``argv`` for ``cls`` and run it: the body of every ``services/<wing>/__main__.py``.
    A bad option or option value is one line on stderr and exit code 2."""
    try:
        args = parser_for(cls).parse_args(argv)
    except UsageError as exc:
        return int(exc.code)
    configure_logging(cls.name)
    try:
        return run_process(from_args(cls, args))
    except ValueError as exc:
        print(f"acnmp serve {cls.name}: error: {exc}", file=sys.stderr)
        return 2
