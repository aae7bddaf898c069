"""Argparse types shared by every command line (``acnmp ...`` and ``acnmp serve <process>``).

A bad value ends in argparse's one-line error naming the option (exit code 2), before anything
runs. Integers and numbers have an upper bound too, so a huge value is refused there instead of
overflowing later in torch, numpy or the wire codec with a message that names no option.
:func:`check_output_path` checks, after parsing, that a file a command will write can be written.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import stat
import sys
from pathlib import Path

import zenoh

from .keys import check_name

#: The largest integer a count, a number of steps or a seed may be (fits every int32 and a numpy seed).
MAX_INT = 2**31 - 1
#: The largest number of seconds a timeout or a delay may be (about 31 years).
MAX_SECONDS = 1e9


def int_at_least(lo: int, hi: int = MAX_INT):
    """An argparse type: an int from ``lo`` to ``hi``."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {text!r}") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"expected an integer >= {lo}, got {value}")
        if value > hi:
            raise argparse.ArgumentTypeError(f"expected an integer <= {hi}, got {value}")
        return value
    return parse


#: The most seeds one ``--seeds`` may name (each is a whole run of an experiment).
MAX_SEEDS = 10_000
#: What ``--seeds`` takes, for its help and its errors.
SEEDS_HELP = "a count N (seeds 0..N-1) or the seeds themselves: A-B (A to B), A,B,C or a mix (0-4,100)"


def seeds(text: str) -> list[int]:
    """An argparse type: the seeds to run, in order. ``"N"`` alone is a count, seeds 0..N-1 (N >= 1);
    otherwise comma-separated seeds and inclusive ranges ``A-B`` (``"3-3"`` is seed 3 alone,
    ``"0-4,100"`` six seeds); each seed from 0 to :data:`MAX_INT`, none twice, at most
    :data:`MAX_SEEDS` of them."""
    bad = argparse.ArgumentTypeError(f"expected {SEEDS_HELP}, got {text!r}")
    parts = [p.strip() for p in text.split(",")]
    try:
        if len(parts) == 1 and "-" not in parts[0]:
            count = int(parts[0])
            if not 1 <= count <= MAX_SEEDS:
                raise bad
            return list(range(count))
        out: list[int] = []
        for part in parts:
            lo, dash, hi = part.partition("-")
            first, last = int(lo), int(hi) if dash else int(lo)
            if not 0 <= first <= last <= MAX_INT or len(out) + last - first >= MAX_SEEDS:
                raise bad
            out.extend(range(first, last + 1))
    except ValueError:
        raise bad from None
    if len(set(out)) != len(out):
        raise argparse.ArgumentTypeError(f"expected every seed once, got {text!r}")
    return out


def seconds(*, zero: bool = False, hi: float = MAX_SECONDS):
    """An argparse type: a finite number of seconds > 0 (``zero=True``: >= 0), at most ``hi``."""
    bound = ">= 0" if zero else "> 0"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number {bound}, got {text!r}") from None
        if not (math.isfinite(value) and (value >= 0 if zero else value > 0)):
            raise argparse.ArgumentTypeError(f"expected a number {bound}, got {text!r}")
        if value > hi:
            raise argparse.ArgumentTypeError(f"expected a number <= {hi:g}, got {text!r}")
        return value
    return parse


def non_empty(text: str) -> str:
    """An argparse type: a file or directory name that is not empty (``--json ""`` would otherwise
    mean "no file", or the current directory)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a file or directory name, got {text!r}")
    return text


def key_name(kind: str):
    """An argparse type: a name that is one key chunk (:func:`services.transport.keys.check_name`),
    such as a namespace."""
    def parse(text: str) -> str:
        try:
            return check_name(kind, text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc).removeprefix(f"{kind}: ")) from None
    return parse


def robot_kind(text: str) -> str:
    """An argparse type: a registered robot kind, or a plugin ``package.module:attr`` (loaded and
    registered, :mod:`acnmp_core.robots.registry`); returns the kind. The error is one line naming
    the known kinds, or the plugin and why it could not be loaded."""
    from acnmp_core.errors import UnknownRobotError
    from acnmp_core.robots.registry import robot

    try:
        return robot(text).kind
    except UnknownRobotError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("robot: ")) from None


def robot_help(what: str) -> str:
    """The ``--help`` text of a robot option: ``what``, the kinds known here, how to name a plugin."""
    from acnmp_core.robots.registry import robot_kinds

    return (f"{what}: one of {', '.join(robot_kinds())} (`acnmp robots` lists them), or a plugin "
            f"package.module:attr")


def device(text: str) -> str:
    """``--device``: ``cpu``, ``cuda``, ``cuda:N`` or ``auto``, present on this machine
    (:func:`acnmp_core.model.device.resolve_device`); returns the name as given."""
    from acnmp_core.model.device import resolve_device

    try:
        resolve_device(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).split(": ", 1)[1]) from None
    return text


def endpoint(text: str) -> str:
    """An argparse type: a zenoh endpoint ``<protocol>/<address>`` as zenoh parses it (for the
    endpoints a command writes into config files rather than opening a session on)."""
    try:
        zenoh.Config().insert_json5("connect/endpoints", json.dumps([text]))
    except zenoh.ZError:
        raise argparse.ArgumentTypeError(f"expected an endpoint <protocol>/<address>, e.g. tcp/router:7447, "
                                          f"got {text!r}") from None
    return text


class UsageError(SystemExit):
    """A bad argument, already reported on stderr (exit code 2)."""


#: An argument that starts with a minus and a digit (or ``-.`` and a digit) is a value, never an
#: option: ``--obs -5:0,0`` (a time of -5), ``--task-params -1,2``. argparse alone takes only plain
#: negative numbers (``-5``, ``-.5``) for values and reads ``-5:0,0`` as an unknown option.
NEGATIVE_VALUE = re.compile(r"^-\.?\d")


class Parser(argparse.ArgumentParser):
    """An argument parser whose mistakes are one line on stderr, naming the option and how to get
    help (argparse's usage block would come first otherwise); the parsers of sub-commands are of
    this class too (argparse makes them of their parent's). Raises :class:`UsageError`. A value
    that starts with a minus and a digit is taken as a value (:data:`NEGATIVE_VALUE`): no option
    of ours looks like that."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # argparse's own hook (an attribute of 3.11-3.13): what looks like a negative number
        self._negative_number_matcher = NEGATIVE_VALUE

    def error(self, message: str):
        print(f"{self.prog}: error: {message} (see {self.prog} --help)", file=sys.stderr)
        raise UsageError(2)


def check_output_path(path: str | None, option: str) -> None:
    """ValueError naming ``option`` unless a file can be written at ``path`` (None: nothing to check).

    Creates missing parent directories (as the writers do) and probes the file itself, so a run
    of minutes never ends with a result it cannot save. A probe file it created is removed.
    """
    if not path:
        return
    p = Path(path)
    if p.is_dir():
        raise ValueError(f"{option} {path}: is a directory; give a file name")
    if p.exists() and not stat.S_ISREG(p.stat().st_mode):  # /dev/full opens, then every write fails
        raise ValueError(f"{option} {path}: not a regular file; give a file name")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        existed = p.exists()
        with open(p, "a"):
            pass
        if not existed:
            os.unlink(p)
    except OSError as exc:
        raise ValueError(f"{option} {path}: cannot write there ({exc.strerror or exc})") from None
