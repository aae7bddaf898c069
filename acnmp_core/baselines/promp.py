"""Probabilistic Movement Primitives (ProMPs): the baseline movement representation.

A ProMP represents a D-dimensional trajectory as ``y_d(t) = phi(t) . w_d`` with K normalised Gaussian
basis functions ``phi`` over the phase ``z = (t - t0) / (t1 - t0)`` and a Gaussian over the stacked
weights ``w = [w_1, ..., w_D]`` (D*K,), learnt from demonstrations. Conditioning on via-points is
Gaussian conditioning of that weight distribution and gives a new ProMP.

References
----------
Paraschos, Daniel, Peters, Neumann: Probabilistic Movement Primitives, NeurIPS 2013.
Paraschos et al.: Using probabilistic movement primitives in robotics, Autonomous Robots 2018.

Units: times in whatever unit the demonstrations use (the project uses phase in [0, 1]); values in
the demonstrations' raw units. Objects are immutable in use: every operation returns new arrays or a
new :class:`ProMP`.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..validation import check_array, check_positive_int


def _as_generator(rng) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, (int, np.integer)):
        return np.random.default_rng(rng)
    raise ValueError(f"rng: expected a numpy Generator, an int seed or None, got {type(rng).__name__}")


def _psd_sqrt(cov: np.ndarray) -> np.ndarray:
    """A factor ``L`` with ``L @ L.T == cov`` for a symmetric PSD (possibly singular) matrix.

    Eigen-decomposition rather than Cholesky: a covariance learnt from fewer demonstrations than
    weights is singular, and conditioning on noiseless via-points makes it so too.
    """
    vals, vecs = np.linalg.eigh((cov + cov.T) / 2)
    return vecs * np.sqrt(np.clip(vals, 0.0, None))


class ProMP:
    """A ProMP with ``n_basis`` normalised RBFs per output dimension.

    Parameters
    ----------
    n_dims : D, number of output dimensions.
    n_basis : K, basis functions per dimension (>= 2).
    time_range : (t0, t1) mapped to phase 0 and 1; centres are spread uniformly over [0, 1].
    width : RBF standard deviation in phase units; default the centre spacing (neighbouring bases
        overlap enough for smooth trajectories, little enough to fit a 300-step demo closely).
    weight_mean : (D*K,) mean of the weights, dimension-major (``w[d*K + k]``); default zeros.
    weight_cov : (D*K, D*K) covariance of the weights; default identity.
    noise_var : (D,) observation-noise variance per dimension (the demos' fit residual); default zeros.
    """

    def __init__(
        self,
        n_dims: int,
        n_basis: int = 20,
        *,
        time_range: Sequence[float] = (0.0, 1.0),
        width: float | None = None,
        weight_mean=None,
        weight_cov=None,
        noise_var=None,
    ) -> None:
        self.n_dims = check_positive_int("n_dims", n_dims)
        self.n_basis = check_positive_int("n_basis", n_basis, minimum=2)
        tr = check_array("time_range", time_range, shape=(2,))
        if tr[1] <= tr[0]:
            raise ValueError(f"time_range: expected t0 < t1, got {tr.tolist()}")
        self.time_range = (float(tr[0]), float(tr[1]))
        self.centers = np.linspace(0.0, 1.0, self.n_basis)
        spacing = 1.0 / (self.n_basis - 1)
        self.width = float(spacing if width is None else width)
        if not self.width > 0:
            raise ValueError(f"width: expected a positive RBF width, got {width}")
        nw = self.n_weights
        self.weight_mean = (np.zeros(nw) if weight_mean is None
                            else check_array("weight_mean", weight_mean, shape=(nw,)).copy())
        self.weight_cov = (np.eye(nw) if weight_cov is None
                           else check_array("weight_cov", weight_cov, shape=(nw, nw)).copy())
        self.weight_cov = (self.weight_cov + self.weight_cov.T) / 2
        self.noise_var = (np.zeros(self.n_dims) if noise_var is None
                          else check_array("noise_var", noise_var, shape=(self.n_dims,)).copy())
        if np.any(self.noise_var < 0):
            raise ValueError("noise_var: expected non-negative variances")
        self._sqrt_cache: np.ndarray | None = None

    # ------------------------------------------------------------------ basics
    @property
    def n_weights(self) -> int:
        """D*K, the length of the weight vector."""
        return self.n_dims * self.n_basis

    def _like(self, weight_mean, weight_cov) -> "ProMP":
        return ProMP(self.n_dims, self.n_basis, time_range=self.time_range, width=self.width,
                     weight_mean=weight_mean, weight_cov=weight_cov, noise_var=self.noise_var)

    def with_distribution(self, weight_mean, weight_cov) -> "ProMP":
        """A new ProMP with the same basis and the given weight mean (D*K,) and covariance (D*K, D*K)."""
        return self._like(weight_mean, weight_cov)

    def _times(self, times, name: str = "times") -> np.ndarray:
        return check_array(name, times, ndim=1, min_size=1)

    def basis(self, times) -> np.ndarray:
        """(T, K) normalised RBF activations at ``times`` (T,); each row sums to 1."""
        t = self._times(times)
        t0, t1 = self.time_range
        z = (t - t0) / (t1 - t0)
        # Subtract the row maximum before exp: far outside [0, 1] every activation would underflow.
        logits = -0.5 * ((z[:, None] - self.centers[None, :]) / self.width) ** 2
        act = np.exp(logits - logits.max(axis=1, keepdims=True))
        return act / act.sum(axis=1, keepdims=True)

    def _design(self, times) -> np.ndarray:
        """(T*D, D*K) block-diagonal design matrix mapping weights to the stacked trajectory
        ``y.reshape(-1)`` of a (T, D) trajectory (time-major)."""
        phi = self.basis(times)
        return np.kron(phi, np.eye(self.n_dims))[:, self._perm()]

    def _perm(self) -> np.ndarray:
        # kron(phi, I_D) orders columns as (k, d); the weight vector is ordered (d, k).
        k, d = np.meshgrid(np.arange(self.n_basis), np.arange(self.n_dims), indexing="xy")
        return (k * self.n_dims + d).reshape(-1)

    # ------------------------------------------------------------------ trajectories
    def trajectories_from_weights(self, weights, times) -> np.ndarray:
        """Trajectories of weight vectors: weights (B, D*K) or (D*K,) -> (B, T, D) or (T, D)."""
        w = check_array("weights", weights, ndim=(1, 2))
        if w.shape[-1] != self.n_weights:
            raise ValueError(f"weights: expected {self.n_weights} weights on the last axis, got {w.shape[-1]}")
        phi = self.basis(times)
        out = np.einsum("tk,bdk->btd", phi, w.reshape(-1, self.n_dims, self.n_basis))
        return out[0] if w.ndim == 1 else out

    def mean_trajectory(self, times) -> np.ndarray:
        """(T, D) mean trajectory at ``times`` (T,)."""
        return self.trajectories_from_weights(self.weight_mean, times)

    def cov_trajectory(self, times, *, include_noise: bool = False) -> np.ndarray:
        """(T, D, D) covariance between the output dimensions at each time (marginal over time)."""
        phi = self.basis(times)
        c = self.weight_cov.reshape(self.n_dims, self.n_basis, self.n_dims, self.n_basis)
        cov = np.einsum("tk,dkel,tl->tde", phi, c, phi)
        if include_noise:
            cov = cov + np.diag(self.noise_var)[None]
        return cov

    def var_trajectory(self, times, *, include_noise: bool = False) -> np.ndarray:
        """(T, D) variance of each output dimension at each time."""
        return np.clip(np.diagonal(self.cov_trajectory(times, include_noise=include_noise), axis1=1, axis2=2),
                       0.0, None)

    def std_trajectory(self, times, *, include_noise: bool = False) -> np.ndarray:
        """(T, D) standard deviation of each output dimension at each time."""
        return np.sqrt(self.var_trajectory(times, include_noise=include_noise))

    def sample_weights(self, n_samples: int, rng=None) -> np.ndarray:
        """(n_samples, D*K) weight vectors drawn with ``rng`` (a Generator or an int seed)."""
        n = check_positive_int("n_samples", n_samples)
        gen = _as_generator(rng)
        if self._sqrt_cache is None:
            self._sqrt_cache = _psd_sqrt(self.weight_cov)
        eps = gen.standard_normal((n, self.n_weights))
        return self.weight_mean + eps @ self._sqrt_cache.T

    def sample_trajectories(self, times, n_samples: int, rng=None) -> np.ndarray:
        """(n_samples, T, D) trajectories drawn with ``rng`` (a Generator or an int seed).

        The same seed gives the same samples.
        """
        return self.trajectories_from_weights(self.sample_weights(n_samples, rng).reshape(-1, self.n_weights), times)

    # ------------------------------------------------------------------ learning
    def weights_from_trajectory(self, times, values, *, ridge: float = 1e-6) -> np.ndarray:
        """(D*K,) ridge-regression weights of one trajectory: times (T,), values (T, D)."""
        t = self._times(times)
        y = check_array("values", values, shape=(t.shape[0], self.n_dims))
        phi = self.basis(t)
        a = phi.T @ phi + ridge * np.eye(self.n_basis)
        w = np.linalg.solve(a, phi.T @ y)  # (K, D)
        return w.T.reshape(-1)

    @classmethod
    def from_demos(
        cls,
        times,
        values,
        *,
        n_basis: int = 20,
        time_range: Sequence[float] | None = None,
        normalize_duration: bool = False,
        width: float | None = None,
        ridge: float = 1e-6,
        cov_reg: float = 1e-6,
    ) -> "ProMP":
        """Learn a ProMP from demonstrations that may differ in length and time grid.

        Parameters
        ----------
        times : sequence of N arrays (T_i,) or an (N, T) array; strictly increasing per demo.
        values : sequence of N arrays (T_i, D) or an (N, T, D) array.
        n_basis : K basis functions per dimension.
        time_range : (t0, t1) of the phase; default the smallest and largest demo time, or (0, 1)
            with ``normalize_duration``.
        normalize_duration : map each demo's own [first, last] time onto [0, 1] (temporal
            normalisation for demos of different durations); query the result in phase [0, 1].
        ridge : Tikhonov regularisation of each demo's weight regression (keeps the fit stable when
            a demo has fewer points than basis functions).
        cov_reg : added to the weight covariance's diagonal (units of values squared). It keeps the
            covariance invertible with fewer demos than weights, and gives conditioning room to reach
            via-points outside the demonstrations' span.

        Returns
        -------
        ProMP with the weights' sample mean and covariance (ddof 1; zero with one demo), and the
        per-dimension mean squared fit residual as ``noise_var``.
        """
        ts, ys = _demo_lists(times, values)
        d = ys[0].shape[1]
        if normalize_duration:
            ts = [(t - t[0]) / (t[-1] - t[0]) for t in ts]
            time_range = (0.0, 1.0) if time_range is None else time_range
        if time_range is None:
            lo, hi = min(t[0] for t in ts), max(t[-1] for t in ts)
            time_range = (lo, hi)
        base = cls(d, n_basis, time_range=time_range, width=width)
        w = np.stack([base.weights_from_trajectory(t, y, ridge=ridge) for t, y in zip(ts, ys)])
        mean = w.mean(axis=0)
        cov = np.cov(w, rowvar=False, ddof=1) if len(w) > 1 else np.zeros((base.n_weights, base.n_weights))
        cov = np.atleast_2d(cov) + cov_reg * np.eye(base.n_weights)
        resid = np.concatenate([y - base.trajectories_from_weights(wi, t) for t, y, wi in zip(ts, ys, w)])
        return cls(d, n_basis, time_range=time_range, width=base.width, weight_mean=mean, weight_cov=cov,
                   noise_var=np.mean(resid**2, axis=0))

    # ------------------------------------------------------------------ conditioning
    def condition(self, times, values, *, std=0.0, mask=None) -> "ProMP":
        """A new ProMP conditioned on via-points (this one is unchanged).

        Parameters
        ----------
        times : (M,) via-point times.
        values : (M, D) desired values there.
        std : observation standard deviation, a scalar or (M, D); 0 asks the trajectory to pass
            through the points exactly (a relative 1e-12 jitter keeps the solve well posed).
        mask : (M, D) bool, which entries of ``values`` are observed (default all); unobserved
            dimensions stay free.

        Returns
        -------
        ProMP whose mean passes through the via-points (up to ``std``) and whose variance there
        shrinks to ``std**2``.
        """
        t = self._times(times)
        m = t.shape[0]
        y = check_array("values", values, shape=(m, self.n_dims))
        s = check_array("std", std, ndim=(0, 2))
        if s.ndim == 2 and s.shape != (m, self.n_dims):
            raise ValueError(f"std: expected a scalar or shape ({m}, {self.n_dims}), got {s.shape}")
        if np.any(s < 0):
            raise ValueError("std: expected non-negative standard deviations")
        s = np.broadcast_to(s, (m, self.n_dims))
        if mask is None:
            sel = np.ones(m * self.n_dims, dtype=bool)
        else:
            mk = np.asarray(mask)
            if mk.shape != (m, self.n_dims) or mk.dtype != bool:
                raise ValueError(f"mask: expected a bool array of shape ({m}, {self.n_dims})")
            sel = mk.reshape(-1)
            if not sel.any():
                raise ValueError("mask: expected at least one observed entry")
        h = self._design(t)[sel]  # (O, D*K)
        obs = y.reshape(-1)[sel]
        sh = self.weight_cov @ h.T  # (D*K, O)
        prior = h @ sh
        r = s.reshape(-1)[sel] ** 2 + 1e-12 * max(float(np.trace(prior)) / len(obs), 1e-12)
        gram = prior + np.diag(r)
        gain = np.linalg.solve(gram, sh.T).T  # Sigma H^T (H Sigma H^T + R)^-1, via a symmetric solve
        mean = self.weight_mean + gain @ (obs - h @ self.weight_mean)
        cov = self.weight_cov - gain @ sh.T
        return self._like(mean, (cov + cov.T) / 2)


def _demo_lists(times, values) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Normalise demonstration input to lists of (T_i,) times and (T_i, D) values, with checks."""
    if isinstance(values, np.ndarray) and values.ndim == 3:
        vs = [values[i] for i in range(values.shape[0])]
    else:
        vs = list(values)
    if isinstance(times, np.ndarray) and times.ndim in (1, 2):
        ts = [times] * len(vs) if times.ndim == 1 else [times[i] for i in range(times.shape[0])]
    else:
        ts = list(times)
    if not vs:
        raise ValueError("values: expected at least one demonstration")
    if len(ts) != len(vs):
        raise ValueError(f"times: expected {len(vs)} time arrays (one per demonstration), got {len(ts)}")
    out_t, out_y = [], []
    for i, (t, y) in enumerate(zip(ts, vs)):
        t = check_array(f"times[{i}]", t, ndim=1, min_size=2)
        y = check_array(f"values[{i}]", y, ndim=2)
        if y.shape[0] != t.shape[0]:
            raise ValueError(f"values[{i}]: expected {t.shape[0]} rows (one per time), got {y.shape[0]}")
        if np.any(np.diff(t) <= 0):
            raise ValueError(f"times[{i}]: expected strictly increasing times")
        if y.shape[1] != (out_y[0].shape[1] if out_y else y.shape[1]):
            raise ValueError(f"values[{i}]: expected {out_y[0].shape[1]} output dims, got {y.shape[1]}")
        out_t.append(t)
        out_y.append(y)
    return out_t, out_y
