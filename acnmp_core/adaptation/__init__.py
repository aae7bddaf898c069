"""Adaptation: reinforcement learning with simultaneous supervised learning, then assimilation
(the "A" of ACNMP, Akbulut et al., CoRL 2020, Sec. 3.2).

- :mod:`.adaptation`: the loop, :func:`~acnmp_core.adaptation.loop.adapt` (roll-outs, policy
  steps, supervised steps on the demonstrations).
- :mod:`.config`: what it is asked for and gives back (settings, target, per-iteration log, result).
- :mod:`.credit`: credit assignment and per-step advantages.
- :mod:`.exploration`: the exploration noise (its shape over time) and its std (how it shrinks).
- :mod:`.assimilation`: adding a solution to the demonstrations and training on it.
"""

from ..moved import forward

__getattr__ = forward(__name__)  # this package was a module: its old names, with a warning
