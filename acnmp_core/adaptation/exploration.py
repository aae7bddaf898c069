"""Time-correlated exploration noise for trajectory-level reinforcement learning.

A few Gaussian knots spread over the trajectory are interpolated by normalised Gaussian radial
basis functions, so a perturbation is smooth in time (a robot can follow it) and its marginal
standard deviation is the same at every step (:class:`SmoothNoise`). :class:`CubicNoise` is the
authors' E4 noise: a few Gaussian samples smoothed into one cubic polynomial over the trajectory.
"""
from __future__ import annotations

import numpy as np

from ..validation import check_array, check_positive_int
from .config import AdaptConfig


class _KnotNoise:
    """Noise ``basis @ knots``: ``self.basis`` (T, K) maps K iid Gaussian knots to T steps."""

    basis: np.ndarray
    n_knots: int

    def sample(self, n: int, n_dims: int, rng: np.random.Generator, std=1.0) -> np.ndarray:
        """Draw ``n`` noise trajectories of shape (n, T, n_dims); ``std`` (scalar or (n_dims,), in
        whatever units the caller works in) scales the knots of each dimension."""
        n = check_positive_int("n", n, minimum=0)
        std = check_array("std", std, ndim=(0, 1))
        knots = rng.standard_normal((n, self.n_knots, n_dims))
        return np.einsum("tk,nkd->ntd", self.basis, knots) * std


class SmoothNoise(_KnotNoise):
    """Smooth Gaussian noise over ``n_steps`` time steps; its std is ``std`` at every step.

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


class CubicNoise(_KnotNoise):
    """The authors' E4 exploration noise: ``n_knots`` iid Gaussian samples at evenly spaced times,
    replaced by their least-squares cubic polynomial in time.

    Their notebook (``Experiment4/ACNMP-Fourth experiment.ipynb``, ``rl_agent``) draws 20 samples of
    std ``var`` per joint and smooths them with ``UnivariateSpline(k=3, s=0.1)``; at their stds
    (``min(3 x error, 0.08)`` rad, about 0.05 near the end) the residual allowance s = 0.1 exceeds
    the samples' scatter about a cubic, so the spline has no interior knot: the least-squares cubic.
    The result is far smoother than :class:`SmoothNoise` with as many knots (4 degrees of freedom
    per output) and its std per step is not uniform: about 0.34 x ``std`` mid-trajectory and 0.77 x
    at the ends (0.42 x on average, :meth:`step_std`); ``std`` is the samples', as in their code.

    Parameters
    ----------
    n_steps : T, trajectory length. n_knots : K >= 4 samples (the authors' 20).
    """

    def __init__(self, n_steps: int, n_knots: int = 20) -> None:
        self.n_steps = check_positive_int("n_steps", n_steps)
        self.n_knots = check_positive_int("n_knots", n_knots, minimum=4)
        s = np.linspace(-1.0, 1.0, self.n_steps)
        c = np.linspace(-1.0, 1.0, self.n_knots)
        # (T, K): the cubic fitted to K samples, evaluated at the T steps (Legendre basis: well conditioned)
        vs, vc = np.polynomial.legendre.legvander(s, 3), np.polynomial.legendre.legvander(c, 3)
        self.basis = vs @ np.linalg.pinv(vc)

    def step_std(self) -> np.ndarray:
        """(T,) std of the noise at each step per unit ``std`` of the samples."""
        return np.linalg.norm(self.basis, axis=1)


class DemoNoise:
    """Noise shaped like the demonstrations' differences: a random combination of each
    demonstration's deviation from their mean, so a perturbation moves the outputs together the way
    a change of task parameters moves them (a few task parameters: a few directions), not each
    output on its own.

    Parameters
    ----------
    values : (N, T, D) the N >= 2 demonstrations on the trajectory's T steps (any units; the caller's
        normalised ones).
    """

    def __init__(self, values) -> None:
        values = check_array("values", values, ndim=3)
        if values.shape[0] < 2:
            raise ValueError(f"values: expected at least 2 demonstrations, got {values.shape[0]}")
        dev = values - values.mean(axis=0, keepdims=True)
        # Scaled so the noise's root mean square over the steps and outputs is one unit of ``std``.
        rms = float(np.sqrt((dev**2).sum(axis=0).mean() / (values.shape[0] - 1)))
        if not rms > 0:
            raise ValueError("values: the demonstrations are all the same; there is no direction to explore")
        self.modes = dev / (rms * np.sqrt(values.shape[0] - 1))

    def sample(self, n: int, n_dims: int, rng: np.random.Generator, std=1.0) -> np.ndarray:
        """Draw ``n`` noise trajectories of shape (n, T, n_dims); ``std`` (scalar or (n_dims,))
        scales the root mean square of each output's share."""
        n = check_positive_int("n", n, minimum=0)
        if n_dims != self.modes.shape[2]:
            raise ValueError(f"n_dims: expected {self.modes.shape[2]} (the demonstrations' outputs), got {n_dims}")
        std = check_array("std", std, ndim=(0, 1))
        z = rng.standard_normal((n, self.modes.shape[0]))
        return np.einsum("nk,ktd->ntd", z, self.modes) * std


def explore_std(cfg: AdaptConfig, std0: np.ndarray, scale: np.ndarray, err: float | None,
                 err0: float | None) -> np.ndarray:
    """Exploration std (D,) in normalised units for the next iteration. std0 (D,) the initial std
    (normalised), scale (D,) the outputs' normalisation scale (raw = normalised x scale), err the
    last mean roll-out's error and err0 the first (None before the first roll-out)."""
    if cfg.explore_error_gain is not None:
        raw = cfg.explore_cap if err is None else min(cfg.explore_error_gain * err, cfg.explore_cap)
        return raw / scale
    ratio = err / err0 if err is not None and err0 > 0 else 1.0
    return std0 * float(np.clip(ratio, cfg.explore_min, 1.0))
