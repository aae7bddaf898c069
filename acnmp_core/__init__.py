"""acnmp_core: Adaptive Conditional Neural Movement Primitives as a plain Python library.

Learn a movement skill from a few demonstrations (:class:`CNMP`, :func:`train`), condition it on
via-points and task parameters (:meth:`CNMP.predict`), adapt it by reinforcement learning with
simultaneous supervised learning (:func:`adapt`), and assimilate the solution. No zenoh or rerun
import happens here: the library is usable in a notebook.
"""
from .adaptation import AdaptConfig, AdaptResult, AdaptTarget, adapt
from .checkpoint import load_checkpoint, save_checkpoint
from .cnmp import CNMP, CNMPConfig, Prediction
from .data import DemoSet, Demonstration
from .rollout import RolloutBatch, RolloutEvaluator
from .training import TrainConfig, train

__all__ = [
    "AdaptConfig", "AdaptResult", "AdaptTarget", "adapt", "load_checkpoint", "save_checkpoint", "CNMP",
    "CNMPConfig", "Prediction", "DemoSet", "Demonstration", "RolloutBatch", "RolloutEvaluator",
    "TrainConfig", "train",
]
__version__ = "0.1.0"
