"""The via-point task: 1-D trajectories through a via-point (the evaluator and the demonstrations)."""

from ...moved import forward

__getattr__ = forward(__name__)  # this package was a module: its old names, with a warning
