"""Typed input errors of the library: what was wrong with an argument, as a class.

Every class here is a ``ValueError``, so code that catches ValueError (the CLI, the tests, a
notebook) keeps working; a service tells them apart by type to answer with a machine-readable code
(``services/transport/errors.py`` holds that mapping), never by reading the message.

========================  ==========================================================
class                     raised when
========================  ==========================================================
:class:`InputError`       an argument is wrong in any other way (wrong type, missing)
:class:`ShapeError`       an array has the wrong number of dimensions or sizes
:class:`NonFiniteError`   a float argument holds NaN or inf
:class:`TooLargeError`    an argument exceeds a documented size bound
:class:`UnknownTaskError` a task name is not registered, or a robot does not run it
:class:`UnknownRobotError` a robot kind is not registered
:class:`UnreadableFileError` a file cannot be read as what it should hold (missing,
                          truncated, another format or format version)
========================  ==========================================================

Messages always start with the argument's name (``"obs_values: expected shape (3, 2), ..."``).
"""
from __future__ import annotations


class InputError(ValueError):
    """An argument the caller passed is not acceptable; the message names it."""


class ShapeError(InputError):
    """An array argument has the wrong number of dimensions or the wrong sizes."""


class NonFiniteError(InputError):
    """A float argument (or an element of an array argument) is NaN or infinite."""


class TooLargeError(InputError):
    """An argument is larger than the bound documented for it."""


class UnknownTaskError(InputError):
    """A task name that is not registered, or that the chosen robot kind does not run."""


class UnknownRobotError(InputError):
    """A robot kind that is not in :mod:`acnmp_core.robots.registry`."""


class UnreadableFileError(InputError):
    """A file that cannot be read as what it should hold: missing, truncated, of another format or
    of a format version this library does not read.

    ``path`` is the file, ``reason`` says what is wrong with it without naming it (a state
    directory's quarantine records the two apart); the message names both.
    """

    def __init__(self, path, reason: str, message: str | None = None):
        super().__init__(message or f"path: {path}: {reason}")
        self.path = path
        self.reason = reason
