"""The peers of ACNMP a robot-learning user would pick instead, each the real library at its defaults.

:mod:`.black_box`: episodic black-box RL over a ProMP's weights with CMA-ES (fancy_gym's recipe:
``mp_pytorch`` and ``cma``); :mod:`.step_based`: stable-baselines3's PPO and SAC on the step-based
environment, from scratch or warm-started by behaviour cloning. Each library is imported when a
peer first runs; without it the peer fails with one line naming the ``peers`` extra.
"""
from __future__ import annotations

from importlib import import_module
from types import ModuleType

from ..errors import InputError

#: the extra that installs every peer library
EXTRA = "pip install 'acnmp[peers]'"


def require(module: str, peer: str) -> ModuleType:
    """Import ``module`` for the peer ``peer``; InputError (one line naming the extra) without it."""
    try:
        return import_module(module)
    except ImportError as exc:
        raise InputError(f"{peer} needs {module.split('.')[0]}, from the peers extra: {EXTRA} ({exc})") from None
