"""Resampling an episode onto a fixed number of rows over its phase."""
from __future__ import annotations

import numpy as np


def resample(phase: np.ndarray, values: np.ndarray, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """``values`` (T, D) given at ``phase`` (T,), strictly increasing, linearly interpolated at
    ``rows`` points evenly spaced from the first phase to the last; returns (phase (rows,),
    values (rows, D)). T and ``rows`` must be at least 2."""
    if rows < 2 or len(phase) < 2:
        raise ValueError(f"resample: expected at least 2 rows in and out, got {len(phase)} -> {rows}")
    grid = np.linspace(phase[0], phase[-1], rows)
    out = np.stack([np.interp(grid, phase, values[:, j]) for j in range(values.shape[1])], axis=1)
    return grid, out.reshape(rows, values.shape[1])
