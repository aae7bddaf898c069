"""Skill transfer between two robots through a shared latent space (ACNMP paper Sec. 3.3).

A :class:`TransferPair` is two :class:`~acnmp_core.model.cnmp.CNMP` s, one per robot (robot A with D_A
outputs, robot B with D_B), with latents of the same size L. :func:`train_pair` trains them together
on paired demonstrations (demonstration i of A and of B show the same skill with the same
end-effector path): the Gaussian NLL of each robot's decoder on its own demonstrations plus
``latent_weight`` times the mean squared difference between the latents of paired episodes, so
both encoders map the same skill to the same latent. A skill shown on robot A only is then encoded
by A's encoder and decoded by B's decoder (:meth:`TransferPair.transfer`).

:class:`TransferredSkill` presents "A's observations -> A's encoder -> B's decoder" with the
interface :func:`~acnmp_core.adaptation.loop.adapt` uses, so robot B can refine the transferred skill by
RL (with ``params`` = B's decoder, the authors' choice), its supervised steps on B's own
demonstrations.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import torch
from torch import nn

from ..data.demos import DemoSet
from ..errors import InputError
from ..model.cnmp import CNMP, CNMPConfig, Prediction, Query
from ..model.episodes import Episode
from ..model.optim_step import Stepper
from ..model.training import make_sampler, nll_loss
from ..validation import check_array, check_positive_int
from .config import PairTrainResult, TransferConfig


class TransferPair:
    """Robot A's and robot B's CNMPs over time (no task parameters), latents of one size.

    Parameters: ``n_a`` = D_A and ``n_b`` = D_B outputs, ``cfg`` (:class:`TransferConfig`, for the
    widths), ``seed`` for the weight initialisation. ``model_a`` and ``model_b`` are plain CNMPs.
    """

    def __init__(self, n_a: int, n_b: int, cfg: TransferConfig | None = None, seed: int = 0) -> None:
        cfg = cfg or TransferConfig()
        self.model_a = CNMP(CNMPConfig(n_a, 0, cfg.widths, cfg.widths, prior="none"), seed=seed)
        self.model_b = CNMP(CNMPConfig(n_b, 0, cfg.widths, cfg.widths, prior="none"), seed=seed + 1)

    @classmethod
    def from_models(cls, model_a: CNMP, model_b: CNMP) -> "TransferPair":
        """A pair of two existing CNMPs (e.g. rebuilt from a weights message), used as they are.
        Raises InputError unless both have no task parameters and latents of one size, and unless a
        robot B with a linear path has robot A's outputs: its path is conditioned on the
        observations, and a transferred skill's are robot A's (a pair of two robots' CNMPs trains
        the network alone, as :class:`TransferPair` does)."""
        if model_a.config.n_task_params or model_b.config.n_task_params:
            raise InputError("models: a transfer pair's CNMPs have no task parameters")
        if model_a.config.latent_dim != model_b.config.latent_dim:
            raise InputError(f"model_b: latent size {model_b.config.latent_dim} differs from model_a's "
                             f"{model_a.config.latent_dim}")
        if model_b.config.prior != "none" and tuple(model_b.config.output_names) != tuple(model_a.config.output_names):
            raise InputError("model_b: its linear path is conditioned on observations of its own outputs "
                             f"{list(model_b.config.output_names)}, and a transferred skill observes robot A's "
                             f"{list(model_a.config.output_names)}; train robot B's CNMP with prior='none'")
        pair = cls.__new__(cls)
        pair.model_a, pair.model_b = model_a, model_b
        return pair

    def latent_a(self, times, values_a) -> np.ndarray:
        """Latent (L,) of robot A's observations: times (N,), values_a (N, D_A) raw units."""
        return self.model_a.encode_demo(times, values_a)

    def latent_b(self, times, values_b) -> np.ndarray:
        """Latent (L,) of robot B's observations: times (N,), values_b (N, D_B) raw units."""
        return self.model_b.encode_demo(times, values_b)

    def transfer(self, obs_times, obs_values_a, query_times) -> Prediction:
        """Robot B's trajectory for the skill robot A shows in its observations.

        obs_times (N,), obs_values_a (N, D_A) robot A's observations (raw units); query_times (T,).
        Returns a :class:`~acnmp_core.model.cnmp.Prediction` of robot B: times (T,), mean (T, D_B),
        std (T, D_B) raw units, latent (L,) the latent A's encoder gave.
        """
        view = TransferredSkill(self)
        return view.predict_query(view.make_query(obs_times, obs_values_a, None, query_times))


def _paired_episodes(samplers, batch_size: int, n_demos: int, gen: torch.Generator) -> tuple[Episode, Episode]:
    """One batch of episodes from A's and B's samplers drawn from the same demonstrations."""
    idx = torch.randint(0, n_demos, (batch_size,), generator=gen)
    return samplers[0].sample(batch_size, gen, idx), samplers[1].sample(batch_size, gen, idx)


def train_pair(pair: TransferPair, demos_a: DemoSet, demos_b: DemoSet, cfg: TransferConfig | None = None, *,
               seed: int = 0, on_step: Callable[[int, PairTrainResult], None] | None = None) -> PairTrainResult:
    """Train both CNMPs of ``pair`` in place on paired demonstrations.

    demos_a (n demos of (T, D_A)) and demos_b (n of (T, D_B)), raw units; demonstration i of one
    pairs with demonstration i of the other. Each step draws ``batch_size`` demonstrations, an
    episode of each robot from each (its own observation and target times), and minimises
    ``NLL_A + NLL_B + latent_weight * mean((r_A - r_B)^2)``. Deterministic given ``seed``.
    ``on_step(steps_done, losses_so_far)`` is called after every step (a service reports progress
    from it, or raises to stop the training; the models are then left half-trained, in train mode).
    Returns the per-step losses.
    """
    cfg = cfg or TransferConfig()
    if len(demos_a) != len(demos_b):
        raise ValueError(f"demos_b: expected {len(demos_a)} demonstrations paired with demos_a, got {len(demos_b)}")
    a, b = pair.model_a, pair.model_b
    a.fit_normalization(demos_a)
    b.fit_normalization(demos_b)
    scfg = cfg.sampling()
    samplers = (make_sampler(a, demos_a, scfg), make_sampler(b, demos_b, scfg))
    gen = torch.Generator().manual_seed(seed)
    opt = Stepper(torch.optim.Adam([*a.parameters(), *b.parameters()], lr=cfg.lr))
    result = PairTrainResult()
    a.train()
    b.train()
    for _ in range(cfg.steps):
        ep_a, ep_b = _paired_episodes(samplers, cfg.batch_size, len(demos_a), gen)
        la, lb = nll_loss(a, ep_a), nll_loss(b, ep_b)
        align = ((a.encode(ep_a.obs_x, ep_a.obs_mask) - b.encode(ep_b.obs_x, ep_b.obs_mask)) ** 2).mean()
        loss = la + lb + cfg.latent_weight * align if cfg.latent_weight > 0 else la + lb
        opt.zero_grad()
        loss.backward()
        opt.step()
        result.nll_a.append(la.item())
        result.nll_b.append(lb.item())
        result.align.append(align.item())
        if on_step is not None:
            on_step(len(result.align), result)
    a.eval()
    b.eval()
    return result


class TransferredSkill(nn.Module):
    """Robot B's skill conditioned on robot A's observations: A's encoder, then B's decoder.

    The interface :func:`~acnmp_core.adaptation.loop.adapt` uses on a model: :meth:`make_query` takes
    robot A's observations (N, D_A) and gives a :class:`~acnmp_core.model.cnmp.Query` whose targets are
    B's (``config`` and ``value_norm`` are B's, so trajectories come out as (T, D_B));
    :meth:`mean_normalized` runs A's encoder and B's decoder; ``forward`` and :meth:`pack` are
    robot B's own CNMP's, so adapt()'s supervised steps train on B's demonstrations. Pass
    ``params=view.decoder_parameters()`` to adapt() to train B's decoder only.
    """

    def __init__(self, pair: TransferPair) -> None:
        super().__init__()
        self.model_a, self.model_b = pair.model_a, pair.model_b
        self.config = self.model_b.config
        self.value_norm = self.model_b.value_norm

    def decoder_parameters(self) -> list[nn.Parameter]:
        """Robot B's decoder's parameters (what the authors' RL in robot B trains)."""
        return list(self.model_b.decoder.parameters())

    def make_query(self, obs_times, obs_values, task_params=None, query_times=None, *, n_steps=None,
                   obs_dims_mask=None) -> Query:
        """Robot A's observations obs_times (N,), obs_values (N, D_A) raw; query_times (T,) or
        n_steps. Returns the :class:`Query`: obs_x normalised for A's encoder, tgt_x for B's decoder."""
        if task_params is not None and np.asarray(task_params).size:
            raise ValueError("task_params: a transferred skill has none (time is its only input)")
        qa = self.model_a.make_query(obs_times, obs_values, None, query_times, n_steps=n_steps,
                                     obs_dims_mask=obs_dims_mask)
        # B's targets (normalised by B's own time statistics); the dummy observation is never encoded.
        qb = self.model_b.make_query(qa.times[:1], np.zeros((1, self.config.n_outputs)), None, qa.times)
        return Query(obs_x=qa.obs_x, obs_mask=qa.obs_mask, tgt_x=qb.tgt_x, times=qa.times)

    def forward(self, obs_x, obs_mask, tgt_x):
        """Robot B's own CNMP (B's observations (B, N, 1+2 D_B)): used on B's demonstrations."""
        return self.model_b(obs_x, obs_mask, tgt_x)

    def pack(self, demos: DemoSet):
        """Robot B's demonstrations packed for B's CNMP (see :meth:`CNMP.pack`)."""
        return self.model_b.pack(demos)

    def latent(self, query: Query) -> torch.Tensor:
        """Latent (1, L) of A's observations in ``query`` (A's encoder is not trained here), as A's
        own predictions encode them (clipped to A's range where A has a linear path)."""
        with torch.no_grad():
            return self.model_a.encode(self.model_a.network_obs(query.obs_x), query.obs_mask)

    def _decode(self, query: Query) -> tuple[torch.Tensor, torch.Tensor]:
        """B's decoder on A's latent, plus what B's linear path (if any) adds given A's observations,
        which are in B's outputs (:meth:`TransferPair.from_models`): mean, std (1, T, D_B) normalised."""
        b = self.model_b
        mean, std = b.decode(self.latent(query), b.network_targets(query.tgt_x))
        if b.prior is None:
            return mean, std
        a = self.model_a
        d = b.config.n_outputs
        x = query.obs_x.double()
        # A's normalised observations in raw units, then in B's normalisation (the same outputs)
        dims = x[..., 1 + d:]
        t = b.time_norm.normalize(a.time_norm.denormalize(x[..., :1]))
        v = b.value_norm.normalize(a.value_norm.denormalize(x[..., 1:1 + d])) * dims
        obs_b = torch.cat([t, v, dims], dim=-1).to(query.obs_x.dtype)
        return b._with_prior(mean, query.tgt_x, b.path_weights(obs_b, b.network_obs(obs_b), query.obs_mask)), std

    def mean_normalized(self, query: Query) -> torch.Tensor:
        """Differentiable (in B's decoder) mean (T, D_B), normalised units."""
        return self._decode(query)[0][0]

    def predict_query(self, query: Query) -> Prediction:
        """Robot B's trajectory for ``query``, raw units: mean, std (T, D_B), latent (L,)."""
        with torch.no_grad():
            latent = self.latent(query)
            mean, std = self._decode(query)
            mean = self.value_norm.denormalize(mean[0].double())
            std = self.value_norm.denormalize_std(std[0].double())
        return Prediction(query.times.copy(), mean.numpy(), std.numpy(), latent[0].double().numpy())


def spread_observations(times, values, n_obs: int) -> tuple[np.ndarray, np.ndarray]:
    """``n_obs`` points of a trajectory spread evenly in time: times (T,), values (T, D) ->
    (n_obs,), (n_obs, D) (the conditioning the authors' transfer uses, 11 points)."""
    times = check_array("times", times, ndim=1, min_size=2)
    values = check_array("values", values, ndim=2, shape=(len(times), None))
    n_obs = check_positive_int("n_obs", n_obs)
    idx = np.linspace(0, len(times) - 1, n_obs).round().astype(int)
    return times[idx], values[idx]


def latent_plane(latents) -> np.ndarray:
    """Latents (M, L) -> (M, 2): their coordinates on the plane of their first two principal
    components (centred; a zero column where fewer than two directions vary). The map the paper's
    Fig. 6 draws: paired demonstrations of two robots land on (nearly) the same point when aligned."""
    x = check_array("latents", latents, ndim=2, min_size=1)
    x = x - x.mean(axis=0)
    _, _, vt = np.linalg.svd(x, full_matrices=False)
    out = np.zeros((len(x), 2))
    k = min(2, vt.shape[0])
    out[:, :k] = x @ vt[:k].T
    return out
