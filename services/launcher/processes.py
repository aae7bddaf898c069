"""The processes a deployment is made of: ``acnmp serve <name>`` and what the launcher starts.

Each process is one wing's :class:`~services.transport.service.Service` subclass, run by
``python -m <module>``. Its options live in a class of their own that imports nothing the process
runs (``services/<wing>/config.py``: torch and rerun stay out), so a command line is built and
checked in a fraction of a second; the class that runs it adds :meth:`serve` to those options.
Both are imported on demand (:func:`options_class`, :func:`service_class`), so asking for one
process never imports another's dependencies.
"""
from __future__ import annotations

import importlib

from services.transport.service import Service


#: name -> (the module ``python -m`` runs, "module:OptionsClass", "module:ConfigClass" that runs it).
PROCESSES: dict[str, tuple[str, str, str]] = {
    "model": ("services.model", "services.model.config:ModelOptions", "services.model.service:ModelConfig"),
    "learner": ("services.learner", "services.learner.config:LearnerOptions",
                "services.learner.service:LearnerConfig"),
    "worker": ("services.worker", "services.worker.service:WorkerConfig", "services.worker.service:WorkerConfig"),
    "recorder": ("services.recording", "services.recording.config:RecorderOptions",
                 "services.recording.recorder:RecorderConfig"),
    "router": ("services.transport.router", "services.transport.router:RouterConfig",
               "services.transport.router:RouterConfig"),
}


def _load(path: str) -> type[Service]:
    module, cls = path.split(":")
    return getattr(importlib.import_module(module), cls)


def options_class(name: str) -> type[Service]:
    """The options of process ``name`` (imported now, without what the process runs); KeyError for
    an unknown name."""
    return _load(PROCESSES[name][1])


def service_class(name: str) -> type[Service]:
    """The config class that runs process ``name`` (its options plus ``serve``; imported now);
    KeyError for an unknown name."""
    return _load(PROCESSES[name][2])


def entry_module(name: str) -> str:
    """The module ``python -m`` runs to start process ``name``."""
    return PROCESSES[name][0]
