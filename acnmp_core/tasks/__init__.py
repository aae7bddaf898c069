"""The tasks: each folder holds one task's scene, evaluator (reward and success), demonstrations and
settings together; :mod:`acnmp_core.tasks.registry` maps a task name to its evaluator."""
from . import builtin  # noqa: F401  (registers the built-in tasks)
