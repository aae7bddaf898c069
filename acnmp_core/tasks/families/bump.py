"""A bump whose time moves with the parameter.

``y(t) = exp(-(t - t_c)^2 / (2 w^2))`` with its peak at ``t_c = 0.2 + 0.5 c`` and width ``w = 0.08``:
eight demonstrations at ``c`` = 0, 0.086, ..., 0.6, test conditions beyond them (c in [0.7, 0.85],
the peak up to 0.1 s later than any demonstration's) and between them. A bump moving across a
fixed basis changes the basis weights as a non-linear function of ``c``, so a linear regression of
them (a ProMP conditioned on ``c``) smears the bump when it extrapolates; a network conditioned on
``c`` can move it. The task checks the start, the peak, 1.5 widths either side of it and the end.
"""
from __future__ import annotations

import numpy as np

from .family import PathFamily

WIDTH = 0.08


def peak_time(c: np.ndarray) -> float:
    """The bump's peak phase at condition ``c`` (1,)."""
    return 0.2 + 0.5 * float(np.asarray(c).reshape(-1)[0])


def bump_path(t: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(T, 1) the family's path at phases ``t`` (T,) and condition ``c`` (1,)."""
    t = np.asarray(t, dtype=np.float64)
    return np.exp(-((t - peak_time(c)) ** 2) / (2 * WIDTH**2))[:, None]


def bump_checkpoints(c: np.ndarray) -> np.ndarray:
    """(5,) the phases the task checks: the start, the peak and 1.5 widths either side, the end."""
    tc = peak_time(c)
    return np.array([0.0, tc - 1.5 * WIDTH, tc, tc + 1.5 * WIDTH, 1.0])


BUMP = PathFamily(
    name="bump", output_names=("height",), param_names=("c",), path=bump_path, checkpoints=bump_checkpoints,
    tolerance=0.05, training=np.array([[0.0, 0.6]]), demo_params=np.linspace(0.0, 0.6, 8)[:, None],
    extrapolation=np.array([[0.7, 0.85]]), interpolation=np.array([[0.04, 0.56]]))
