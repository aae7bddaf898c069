"""The wall task: a 2-D point passes a gap in a wall (the evaluator, the settings)."""

from ...moved import forward

__getattr__ = forward(__name__)  # this package was a module: its old names, with a warning
