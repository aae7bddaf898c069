"""The context/target episodes a CNMP trains on, and the sampler that draws them.

An episode picks one demonstration per sample, a few of its points as observations (the context)
and others as targets, in normalised units (Garnelo et al. 2018; Seker et al. 2019).
"""
from __future__ import annotations

from dataclasses import dataclass

import torch

@dataclass
class PackedDemos:
    """Demonstrations padded into tensors (normalised units) for fast batched sampling.

    times (N, Tmax, 1), values (N, Tmax, D), task_params (N, P), lengths (N,) int64.
    """

    times: torch.Tensor
    values: torch.Tensor
    task_params: torch.Tensor
    lengths: torch.Tensor


@dataclass
class Episode:
    """A batch of context/target sets (normalised units).

    obs_x (B, No, 1+P+2D): [t, task_params, values * dim_mask, dim_mask]; obs_mask (B, No) bool;
    tgt_x (B, Nt, 1+P): [t, task_params]; tgt_y (B, Nt, D).
    """

    obs_x: torch.Tensor
    obs_mask: torch.Tensor
    tgt_x: torch.Tensor
    tgt_y: torch.Tensor


class EpisodeSampler:
    """Draws training episodes: per sample a demonstration, 1..max_obs observations, n_targets targets.

    Targets are never among the sample's observations (the authors'), unless
    ``targets_include_obs``: then the targets are the episode's first ``n_targets`` points, its
    observations among them (all of them when ``n_targets`` is at least their number), as in
    conditional neural processes (Garnelo et al. 2018, whose context is a subset of the targets),
    so the model also learns to pass through what it is conditioned on.
    With probability ``partial_obs_prob`` an observation carries only a random non-empty subset of
    the output dimensions, which teaches the model to condition on partial observations.
    ``task_param_jitter`` > 0 moves each episode's task parameters (normalised units) by Gaussian
    noise of that std, the same for its observations and targets: training with input noise
    (Bishop 1995, a smoothness penalty) keeps an output the demonstrations never vary with the
    task parameters from drifting when they are extrapolated (benchmarks/studies/e5_ur10/README.md).
    ``mixup`` > 0: with that probability an episode is a blend ``lam * a + (1 - lam) * b`` (lam
    uniform in [0, 1]) of its demonstration ``a`` and a second random one ``b`` at the same points,
    task parameters and values alike (mixup, Zhang et al. 2018): the model is taught to move
    linearly between demonstrations. It needs demonstrations on one time grid.

    ``packed`` is read once, at construction: the sampler keeps its own float32 table of it (one
    row per demonstration point), so a sampler over demonstrations that changed must be rebuilt.
    """

    def __init__(
        self,
        packed: PackedDemos,
        *,
        min_obs: int = 1,
        max_obs: int = 5,
        n_targets: int = 10,
        partial_obs_prob: float = 0.2,
        targets_include_obs: bool = False,
        task_param_jitter: float = 0.0,
        mixup: float = 0.0,
    ) -> None:
        if isinstance(mixup, bool) or not isinstance(mixup, (int, float)) or not 0 <= mixup <= 1:
            raise ValueError(f"mixup: expected a probability in [0, 1], got {mixup!r}")
        if mixup > 0 and not (bool((packed.lengths == packed.lengths[0]).all())
                              and torch.equal(packed.times, packed.times[:1].expand_as(packed.times))):
            raise ValueError("mixup: expected every demonstration on one time grid (the same times)")
        if isinstance(task_param_jitter, bool) or not isinstance(task_param_jitter, (int, float)) \
                or not 0 <= task_param_jitter < float("inf"):
            raise ValueError(f"task_param_jitter: expected a finite std >= 0, got {task_param_jitter!r}")
        shortest = int(packed.lengths.min())
        if min_obs < 1 or max_obs < min_obs:
            raise ValueError(f"max_obs: expected 1 <= min_obs <= max_obs, got {min_obs}, {max_obs}")
        if max_obs + 1 > shortest:
            raise ValueError(f"max_obs: the shortest demonstration has {shortest} points; need max_obs < {shortest}")
        self.packed = packed
        self.min_obs, self.max_obs = min_obs, max_obs
        self.targets_include_obs = bool(targets_include_obs)
        self.n_targets = max(1, min(n_targets, shortest if self.targets_include_obs else shortest - max_obs))
        self.partial_obs_prob = partial_obs_prob
        self.task_param_jitter = float(task_param_jitter)
        self.mixup = float(mixup)
        n, tmax, d = packed.values.shape
        self._n, self._tmax, self._d = n, tmax, d
        # Every value of an episode is a packed value (times a 0/1 mask, which is exact), so rounding
        # to float32 once here gives the same bits as rounding each episode after the gather; one
        # (N * Tmax, 1 + D) table of [t, values] lets one gather fetch times and values together.
        self._table = torch.cat([packed.times, packed.values], dim=-1).float().reshape(n * tmax, 1 + d)
        self._task_params = packed.task_params.float()
        self._lengths = packed.lengths
        self._padded = bool((packed.lengths < tmax).any())  # all full: the padding mask is a no-op
        self._slots = torch.arange(tmax)[None, :]
        self._obs_slots = torch.arange(max_obs)[None, :]

    def _first_points(self, keys: torch.Tensor, k: int) -> torch.Tensor:
        """Indices (B, k) of the k smallest ``keys`` (B, Tmax) per row, in increasing key order:
        exactly ``argsort(keys)[:, :k]``. A partial sort (top-k) is several times cheaper than a
        full sort; it can only disagree with argsort when keys tie within the first k + 1, which
        random float64 keys almost never do, and then the full sort decides."""
        if k + 1 > keys.shape[1]:
            return torch.argsort(keys, dim=1)[:, :k]
        vals, idx = torch.topk(keys, k + 1, dim=1, largest=False, sorted=True)
        if bool((vals[:, 1:] == vals[:, :-1]).any()):
            return torch.argsort(keys, dim=1)[:, :k]
        return idx[:, :k]

    def sample(self, batch_size: int, gen: torch.Generator, demo_idx: torch.Tensor | None = None) -> Episode:
        """Draw ``batch_size`` episodes using ``gen``; ``demo_idx`` (B,) picks demos (default uniform).

        Returns an :class:`Episode` (float32, normalised units): obs_x (B, max_obs, 1+P+2D),
        obs_mask (B, max_obs), tgt_x (B, n_targets, 1+P), tgt_y (B, n_targets, D).
        """
        n, tmax, d = self._n, self._tmax, self._d
        if demo_idx is None:
            demo_idx = torch.randint(0, n, (batch_size,), generator=gen)
        b = demo_idx.shape[0]
        # A random permutation of each demo's valid indices: invalid (padded) slots sort last.
        keys = torch.rand(b, tmax, generator=gen, dtype=torch.float64)
        if self._padded:
            keys = torch.where(self._slots < self._lengths[demo_idx][:, None], keys, 2.0)
        m = self.max_obs
        # Targets follow the observations in the permutation, or (targets_include_obs) start with them.
        t0 = 0 if self.targets_include_obs else m
        k = max(m, t0 + self.n_targets)
        slots = self._first_points(keys, k)
        points = self._table[slots + demo_idx[:, None] * tmax]  # (B, k, 1 + D)
        n_obs = torch.randint(self.min_obs, self.max_obs + 1, (b,), generator=gen)
        obs_mask = self._obs_slots < n_obs[:, None]
        tp = self._task_params[demo_idx]
        if self.mixup > 0:
            other = torch.randint(0, n, (b,), generator=gen)
            lam = torch.rand(b, generator=gen)
            lam = torch.where(torch.rand(b, generator=gen) < self.mixup, lam, torch.ones(b))[:, None]
            # One time grid: the same slots of the other demonstration are at the same times.
            values = self._table[slots + other[:, None] * tmax][..., 1:]
            points = torch.cat([points[..., :1], lam[:, :, None] * points[..., 1:] + (1 - lam[:, :, None]) * values], -1)
            tp = lam * tp + (1 - lam) * self._task_params[other]
        if self.task_param_jitter > 0 and tp.shape[1]:
            tp = tp + self.task_param_jitter * torch.randn(tp.shape, generator=gen)
        ot, ov = points[:, :m, :1], points[:, :m, 1:]
        dim_mask = torch.ones(b, m, d)
        if self.partial_obs_prob > 0 and d > 1:
            partial = torch.rand(b, self.max_obs, 1, generator=gen) < self.partial_obs_prob
            rand_mask = (torch.rand(b, self.max_obs, d, generator=gen) < 0.5).to(dim_mask.dtype)
            # Guarantee at least one observed dimension per observation.
            first = torch.randint(0, d, (b, self.max_obs), generator=gen)
            rand_mask.scatter_(2, first[..., None], 1.0)
            dim_mask = torch.where(partial, rand_mask, dim_mask)
        obs_x = torch.cat([ot, tp[:, None, :].expand(-1, m, -1), ov * dim_mask, dim_mask], dim=-1)
        tgt = points[:, t0:t0 + self.n_targets]
        tgt_x = torch.cat([tgt[..., :1], tp[:, None, :].expand(-1, self.n_targets, -1)], dim=-1)
        return Episode(obs_x, obs_mask, tgt_x, tgt[..., 1:].contiguous())
