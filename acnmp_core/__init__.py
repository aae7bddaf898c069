"""acnmp_core: Adaptive Conditional Neural Movement Primitives as a plain Python library.

Learn a movement skill from a few demonstrations (:class:`CNMP`, :func:`train`), condition it on
via-points and task parameters (:meth:`CNMP.predict`), adapt it by reinforcement learning with
simultaneous supervised learning (:func:`adapt`), and assimilate the solution. No zenoh or rerun
import happens here: the library is usable in a notebook.

The names below are imported on first use (PEP 562): importing a light submodule such as
``acnmp_core.errors`` or ``acnmp_core.robots.registry`` does not import torch, which takes seconds
and would slow down every process that starts (a restarted worker or recorder, say). Type checkers
and editors read the explicit imports under ``TYPE_CHECKING`` instead, and the package ships
``py.typed`` (PEP 561), so they see every public name with its signature.
"""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from . import moved

moved.install()  # the modules' old names (before 2026-12-05) still import, with a warning

if TYPE_CHECKING:  # what a type checker sees; at run time the same names come from __getattr__
    from .adaptation.loop import adapt
    from .adaptation.config import AdaptConfig, AdaptResult, AdaptTarget
    from .data.demos import Demonstration, DemoSet
    from .model.checkpoint import load_checkpoint, save_checkpoint
    from .model.cnmp import CNMP, CNMPConfig, Prediction
    from .model.training import TrainConfig, train
    from .rollout import RolloutBatch, RolloutEvaluator

#: public name -> submodule that defines it
_EXPORTS = {
    "AdaptConfig": "adaptation.config", "AdaptResult": "adaptation.config", "AdaptTarget": "adaptation.config",
    "adapt": "adaptation.loop",
    "load_checkpoint": "model.checkpoint", "save_checkpoint": "model.checkpoint",
    "CNMP": "model.cnmp", "CNMPConfig": "model.cnmp", "Prediction": "model.cnmp",
    "DemoSet": "data.demos", "Demonstration": "data.demos",
    "RolloutBatch": "rollout", "RolloutEvaluator": "rollout",
    "TrainConfig": "model.training", "train": "model.training",
}

__all__ = ["AdaptConfig", "AdaptResult", "AdaptTarget", "adapt", "load_checkpoint", "save_checkpoint", "CNMP",
           "CNMPConfig", "Prediction", "DemoSet", "Demonstration", "RolloutBatch", "RolloutEvaluator",
           "TrainConfig", "train"]
__version__ = "0.1.0"


def __getattr__(name: str):
    """``acnmp_core.<name>`` for the names of ``__all__``: imported from their submodule on first use."""
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'acnmp_core' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value
