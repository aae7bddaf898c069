"""Affine normalisation of times, task parameters and outputs, stored inside the model.

Users pass raw units everywhere; the network only ever sees normalised values. The statistics are
registered as buffers so that they travel with the weights in a checkpoint.
"""
from __future__ import annotations

import numpy as np
import torch
from torch import nn


class AffineNormalizer(nn.Module):
    """``normalize(x) = (x - shift) / scale`` per feature.

    Parameters
    ----------
    dim : number of features (0 is allowed and makes every call a no-op on empty arrays).

    Buffers ``shift``, ``scale`` (dim,) and the observed range ``low``, ``high`` (dim,) in raw units.
    """

    def __init__(self, dim: int) -> None:
        super().__init__()
        self.dim = int(dim)
        self.register_buffer("shift", torch.zeros(self.dim, dtype=torch.float64))
        self.register_buffer("scale", torch.ones(self.dim, dtype=torch.float64))
        self.register_buffer("low", torch.full((self.dim,), -np.inf, dtype=torch.float64))
        self.register_buffer("high", torch.full((self.dim,), np.inf, dtype=torch.float64))

    def fit(self, data: np.ndarray, mode: str = "standard", min_scale: float = 1e-6) -> "AffineNormalizer":
        """Fit the statistics on ``data`` (N, dim) in raw units.

        ``mode="standard"`` maps to zero mean, unit std; ``mode="range"`` maps [min, max] to [0, 1].
        Constant features get ``scale = 1`` (``min_scale`` guards against division by ~0).
        Returns self.
        """
        if self.dim == 0:
            return self
        data = np.asarray(data, dtype=np.float64).reshape(-1, self.dim)
        lo, hi = data.min(axis=0), data.max(axis=0)
        if mode == "standard":
            shift, scale = data.mean(axis=0), data.std(axis=0)
        elif mode == "range":
            shift, scale = lo, hi - lo
        else:
            raise ValueError(f"mode: expected 'standard' or 'range', got {mode!r}")
        scale = np.where(scale < min_scale, 1.0, scale)
        self.shift.copy_(torch.as_tensor(shift))
        self.scale.copy_(torch.as_tensor(scale))
        self.low.copy_(torch.as_tensor(lo))
        self.high.copy_(torch.as_tensor(hi))
        return self

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        """Raw (..., dim) -> normalised (..., dim), in ``x``'s dtype."""
        return (x - self.shift.to(x.dtype)) / self.scale.to(x.dtype)

    def denormalize(self, x: torch.Tensor) -> torch.Tensor:
        """Normalised (..., dim) -> raw (..., dim)."""
        return x * self.scale.to(x.dtype) + self.shift.to(x.dtype)

    def denormalize_std(self, s: torch.Tensor) -> torch.Tensor:
        """A std in normalised units (..., dim) -> raw units."""
        return s * self.scale.to(s.dtype)

    def range_np(self) -> tuple[np.ndarray, np.ndarray]:
        """Observed (low, high) in raw units, each (dim,)."""
        return self.low.numpy().copy(), self.high.numpy().copy()
