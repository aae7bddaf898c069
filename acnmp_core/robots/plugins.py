"""Robot plugins: robot kinds that come from another package.

A plugin is an object reachable as ``package.module:attr`` that is one of

- a :class:`~acnmp_core.robots.spec.RobotSpec`,
- a list or tuple of them,
- a function taking no argument that returns either.

An installed package offers it through the entry-point group ``acnmp.robots``, e.g. in its
``pyproject.toml``::

    [project.entry-points."acnmp.robots"]
    my_arm = "my_robot.plugin:ROBOT"

and a package that is not installed is named by reference (``--robot my_robot.plugin:ROBOT`` or
the environment variable ``ACNMP_ROBOT_PLUGINS``). This module only finds and loads plugins; the
registry (:mod:`acnmp_core.robots.registry`) registers what they give and keeps their problems.
"""
from __future__ import annotations

import importlib
import os
import sys
from dataclasses import dataclass
from importlib import metadata
from typing import Any

from .spec import RobotSpec

#: the entry-point group installed packages declare their robots in
GROUP = "acnmp.robots"


class PluginError(Exception):
    """A plugin that cannot be loaded; the message is the one-line reason."""


@dataclass(frozen=True)
class PluginProblem:
    """A plugin left out: where it was declared (``source``) and why (``reason``, one line)."""

    source: str
    reason: str

    def __str__(self) -> str:
        return f"robot plugin {self.source} left out: {self.reason}"


@dataclass(frozen=True)
class Found:
    """One plugin to load: ``source`` says where it was declared (for messages and ``acnmp
    robots``), ``ref`` is its ``package.module:attr``."""

    source: str
    ref: str

    def specs(self) -> list[RobotSpec]:
        """The RobotSpecs of this plugin; :class:`PluginError` (one line) when it cannot be imported
        or does not give RobotSpecs."""
        return _as_specs(_resolve(self.ref))


def installed() -> list[Found]:
    """The plugins of the installed packages' ``acnmp.robots`` entry points, sorted by name."""
    try:
        points = metadata.entry_points(group=GROUP)
    except Exception:  # noqa: BLE001 - broken metadata of some unrelated package must not stop the registry
        return []
    found = []
    for ep in sorted(points, key=lambda e: e.name):
        dist = getattr(getattr(ep, "dist", None), "name", None)
        found.append(Found(f"{ep.name!r} (entry point of {dist or 'an installed package'})", ep.value))
    return found


def _resolve(ref: str) -> Any:
    """The object named by ``package.module:attr`` (attr may be dotted); the module is looked for in
    the current directory too (as ``python -m`` would), since a plugin named by reference is
    usually a package one has not installed."""
    module_name, sep, attr = ref.partition(":")
    if not sep or not module_name.strip() or not attr.strip():
        raise PluginError(f"expected package.module:attr, got {ref!r}")
    if os.getcwd() not in sys.path and "" not in sys.path:
        sys.path.append(os.getcwd())
    try:
        obj = importlib.import_module(module_name.strip())
    except Exception as exc:  # noqa: BLE001 - whatever the plugin raises on import is its one-line reason
        raise PluginError(f"cannot import {module_name.strip()!r}: {type(exc).__name__}: {_first_line(exc)}") from None
    for part in attr.strip().split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise PluginError(f"module {module_name.strip()!r} has no attribute {attr.strip()!r}") from None
    return obj


def _as_specs(obj: Any) -> list[RobotSpec]:
    """RobotSpecs from a plugin object (a spec, a sequence of specs, or a function giving either)."""
    if callable(obj) and not isinstance(obj, RobotSpec):
        try:
            obj = obj()
        except Exception as exc:  # noqa: BLE001 - the plugin's own failure, reported in one line
            raise PluginError(f"calling it raised {type(exc).__name__}: {_first_line(exc)}") from None
    items = list(obj) if isinstance(obj, (list, tuple)) else [obj]
    bad = [type(x).__name__ for x in items if not isinstance(x, RobotSpec)]
    if bad or not items:
        raise PluginError(f"expected a RobotSpec (or a list of them, or a function returning them), "
                          f"got {', '.join(bad) or 'an empty list'}")
    return items


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else "(no message)"
