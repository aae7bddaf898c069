"""A planar reach along a circle whose sweep is the parameter.

``p(t) = (cos(phi s(t)), sin(phi s(t)))`` on the unit circle, ``s`` the smoothstep from 0 to 1 and
``phi`` the sweep (rad): eight demonstrations with sweeps 0.6 ... 1.6 rad (34-92 deg), test sweeps
beyond them (1.85-2.15 rad, up to 123 deg) and between them. Every point of the path is a sine or a
cosine of the condition: the demonstrations bend with it, and a linear regression of their basis
weights on ``phi`` leaves the circle when it extrapolates. The task checks the path at five
phases (start, quarters, end) within 3 cm of the circle's point there.
"""
from __future__ import annotations

import numpy as np

from .family import PathFamily


def arc_path(t: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(T, 2) the family's path (x, y) at phases ``t`` (T,) and sweep ``c`` (1,) rad."""
    t = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0)
    angle = float(np.asarray(c).reshape(-1)[0]) * t * t * (3.0 - 2.0 * t)
    return np.stack([np.cos(angle), np.sin(angle)], axis=1)


def arc_checkpoints(c: np.ndarray) -> np.ndarray:
    """(5,) the phases the task checks: the start, the quarters and the end."""
    return np.linspace(0.0, 1.0, 5)


ARC = PathFamily(
    name="arc", output_names=("x", "y"), param_names=("sweep",), path=arc_path, checkpoints=arc_checkpoints,
    tolerance=0.03, training=np.array([[0.6, 1.6]]), demo_params=np.linspace(0.6, 1.6, 8)[:, None],
    extrapolation=np.array([[1.85, 2.15]]), interpolation=np.array([[0.65, 1.55]]))
