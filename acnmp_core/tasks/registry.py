"""Named tasks: a registry from a task name and plain parameters to a RolloutEvaluator.

Services receive a task by name over the wire (an adaptation job, a worker's roll-out request), so
every evaluator they can run is built from JSON-like parameters by the factory registered under its
name: the built-in tasks' in :mod:`acnmp_core.tasks.builtin` (registered when the package
:mod:`acnmp_core.tasks` is imported), a robot plugin's by :func:`add_task`.
"""
from __future__ import annotations

from typing import Any, Callable

from ..rollout import RolloutEvaluator

_FACTORIES: dict[str, Callable[[dict[str, Any]], RolloutEvaluator]] = {}
_CREDITS: dict[str, str] = {}


def register_task(name: str, credit: str = "step"):
    """Decorator: register ``factory(params: dict) -> RolloutEvaluator`` under ``name``.

    ``credit`` is the task's credit for :func:`~acnmp_core.adaptation.loop.adapt` ("step" or "future",
    the ``credit`` attribute of the evaluators it builds), so an evaluator that only forwards
    roll-outs to where the task runs (a remote worker) can carry it too.
    """

    def deco(factory):
        add_task(name, factory, credit)
        return factory

    return deco


def add_task(name: str, factory: Callable[[dict[str, Any]], RolloutEvaluator], credit: str = "step") -> None:
    """Register ``factory(params: dict) -> RolloutEvaluator`` under ``name`` with its ``credit``
    ("step" or "future"); ValueError for a name already taken (a robot plugin cannot replace a task)."""
    if name in _FACTORIES:
        raise ValueError(f"task: {name!r} is already registered")
    if credit not in ("step", "future"):
        raise ValueError(f"credit: expected 'step' or 'future', got {credit!r}")
    _FACTORIES[name] = factory
    _CREDITS[name] = credit


def task_credit(name: str) -> str:
    """The credit ("step" or "future") of the registered task ``name``; ValueError if unknown."""
    if name not in _CREDITS:
        raise ValueError(f"task: unknown task {name!r}; known tasks: {', '.join(task_names())}")
    return _CREDITS[name]


def task_names() -> list[str]:
    """Sorted names of the registered tasks."""
    return sorted(_FACTORIES)


def make_task(name: str, params: dict[str, Any] | None = None) -> RolloutEvaluator:
    """Build the evaluator ``name`` with ``params``; ValueError for an unknown name or bad params."""
    if name not in _FACTORIES:
        raise ValueError(f"task: unknown task {name!r}; known tasks: {', '.join(task_names())}")
    try:
        return _FACTORIES[name](dict(params or {}))
    except KeyError as exc:
        doc = (_FACTORIES[name].__doc__ or "").strip().splitlines()
        needs = f" ({' '.join(line.strip() for line in doc)})" if doc else ""
        raise ValueError(f"params: task {name!r} needs the parameter {exc.args[0]!r}{needs}") from None
    except TypeError as exc:
        raise ValueError(f"params: bad parameters for task {name!r}: {exc}") from None
