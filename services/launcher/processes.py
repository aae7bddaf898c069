"""The processes a deployment is made of: ``acnmp serve <name>`` and what the launcher starts.

Each process is one wing's :class:`~services.transport.service.Service` subclass, run by
``python -m <module>``. Config classes are imported on demand (:func:`service_class`), so asking for
one process never imports another's dependencies.
"""
from __future__ import annotations

import importlib

from services.transport.service import Service

#: name -> (the module ``python -m`` runs, "module:ConfigClass").
PROCESSES: dict[str, tuple[str, str]] = {
    "model": ("services.model", "services.model.service:ModelConfig"),
    "learner": ("services.learner", "services.learner.service:LearnerConfig"),
    "worker": ("services.worker", "services.worker.service:WorkerConfig"),
    "recorder": ("services.recording", "services.recording.recorder:RecorderConfig"),
    "router": ("services.transport.router", "services.transport.router:RouterConfig"),
}


def service_class(name: str) -> type[Service]:
    """The config class of process ``name`` (imported now); KeyError for an unknown name."""
    module, cls = PROCESSES[name][1].split(":")
    return getattr(importlib.import_module(module), cls)


def entry_module(name: str) -> str:
    """The module ``python -m`` runs to start process ``name``."""
    return PROCESSES[name][0]
