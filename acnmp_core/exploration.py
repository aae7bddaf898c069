"""Time-correlated exploration noise for trajectory-level reinforcement learning.

A few Gaussian knots spread over the trajectory are interpolated by normalised Gaussian radial
basis functions, so a perturbation is smooth in time (a robot can follow it) and its marginal
standard deviation is the same at every step.
"""
from __future__ import annotations

import numpy as np

from .validation import check_array, check_positive_int


class SmoothNoise:
    """Smooth Gaussian noise over ``n_steps`` time steps.

    Parameters
    ----------
    n_steps : T, trajectory length.
    n_knots : K, number of independent Gaussian knots; fewer knots give smoother noise.
    width : RBF width as a fraction of the knot spacing (1.0 gives a gentle overlap).
    """

    def __init__(self, n_steps: int, n_knots: int = 5, width: float = 1.0) -> None:
        self.n_steps = check_positive_int("n_steps", n_steps)
        self.n_knots = check_positive_int("n_knots", n_knots)
        if not width > 0:
            raise ValueError(f"width: expected > 0, got {width}")
        s = np.linspace(0.0, 1.0, self.n_steps)
        centres = np.linspace(0.0, 1.0, self.n_knots)
        h = width * (1.0 / max(self.n_knots - 1, 1))
        basis = np.exp(-0.5 * ((s[:, None] - centres[None, :]) / h) ** 2)
        # Unit-norm rows: with iid N(0,1) knots every step then has variance exactly 1.
        self.basis = basis / np.linalg.norm(basis, axis=1, keepdims=True)

    def sample(self, n: int, n_dims: int, rng: np.random.Generator, std=1.0) -> np.ndarray:
        """Draw ``n`` noise trajectories of shape (n, T, n_dims) with per-dimension std ``std``.

        ``std`` is a scalar or (n_dims,) array (in whatever units the caller works in).
        """
        n = check_positive_int("n", n, minimum=0)
        std = check_array("std", std, ndim=(0, 1))
        knots = rng.standard_normal((n, self.n_knots, n_dims))
        return np.einsum("tk,nkd->ntd", self.basis, knots) * std
