"""The UR10 pick-and-place task: the evaluator (reward, success) and the expert demonstrations."""

from ...moved import forward

__getattr__ = forward(__name__)  # this package was a module: its old names, with a warning
