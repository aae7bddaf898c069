"""Conditional Neural Movement Primitives (Seker et al. 2019) over time, task parameters and values.

Encoder: a shared MLP over each observation ``[t, task_params, values * dim_mask, dim_mask]``,
mean-aggregated over the observations into one latent ``r``. Decoder: an MLP over
``[r, t, task_params]`` giving a mean and a softplus std (with a floor) per output dimension.
All normalisation lives inside the model: every public method takes and returns raw units.

With ``CNMPConfig.prior = "linear"`` the mean has a linear path beside the network:
the demonstrations' ProMP jointly Gaussian with their task parameters
(:class:`~acnmp_core.model.prior.LinearPrior`), conditioned on the query's task parameters (in a
skill without task parameters: on its observed points), and the network's mean is added to it, so
the network learns what the linear path misses. The linear path extrapolates demonstrations that vary linearly with their conditions; the
network, which sees the conditions clipped to the range it was trained on (``prior_clip``; the
range widens when a solution beyond it is assimilated, :meth:`CNMP.widen_range`), carries
what is not linear. ``prior = "none"`` is the paper's CNMP.

With ``prior = "trend"`` the network is the paper's CNMP inside the range it was trained on, and
beyond it the linear path carries the change: the network answers the query clipped to that range,
and the linear path's change from the clipped query to the query itself is added. Inside the range
the trend adds nothing, so the network trains and predicts exactly as the paper's. ``prior =
"auto"`` (the default) chooses between "trend" and "none" (one network: whether the trend is added
beyond the range) when the model is trained, from the demonstrations' held-out error at the edges of
their conditions (:mod:`acnmp_core.model.selection`); the config then records the choice.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Sequence

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from ..data.demos import DemoSet
from ..validation import check_array, check_positive_int
from .episodes import PackedDemos
from .normalization import AffineNormalizer
from .prior import LinearPrior, choose_n_basis
from .choice import PriorChoice

#: What the mean is made of (``CNMPConfig.prior``): the network alone ("none", the paper's CNMP),
#: the demonstrations' linear-Gaussian path plus the network's residual ("linear"), the network
#: inside its trained range and the path's trend beyond it ("trend"), or the one of "trend" and
#: "none" the demonstrations need, chosen when the model is trained ("auto", the default).
PRIORS = ("auto", "none", "linear", "trend")
#: the priors with a linear path
PATH_PRIORS = ("linear", "trend")

#: Times may exceed the trained range by this fraction of it before a query is rejected.
TIME_RANGE_TOLERANCE = 0.05


@dataclass
class CNMPConfig:
    """Architecture of a CNMP.

    n_outputs : D, number of sensorimotor output dimensions.
    n_task_params : P, number of external task parameters (0 allowed).
    encoder_widths, decoder_widths : hidden layer widths; the last encoder width is the latent size.
      Defaults follow the paper's appendix table (3 layers of 128 in each).
    std_floor : the smallest std the decoder can output, in normalised units (avoids NLL blow-up).
    output_names, task_param_names : optional labels, carried in checkpoints and service info.
    prior : "auto" (the default): "trend" or "none", chosen from the demonstrations when the model
      is trained (:func:`~acnmp_core.model.selection.choose_prior`; the config then holds the
      choice and ``prior_choice`` why); "trend": the network inside its trained range, the
      demonstrations' linear trend added beyond it; "linear": the mean is the demonstrations'
      linear-Gaussian path plus the network's residual (module docstring); "none": the network
      alone (the paper's CNMP).
    prior_choice : what the "auto" choice measured (:class:`~acnmp_core.model.choice.PriorChoice`),
      None when the prior was given.
    prior_basis : basis functions per output of the linear path; 0 (the default) chooses it by
      leave-one-out error on the demonstrations when the model is fitted to them
      (:func:`~acnmp_core.model.prior.choose_n_basis`), and the config then records the choice.
    prior_clip : with the linear path ("linear"), the network sees task parameters and observed
      values clipped to the range it was trained on (the demonstrations', widened by assimilated
      solutions): beyond it the linear path carries the change and the network adds what it learnt
      at the nearest edge, instead of extrapolating itself. "trend" always clips.
    """

    n_outputs: int
    n_task_params: int = 0
    encoder_widths: Sequence[int] = (128, 128, 128)
    decoder_widths: Sequence[int] = (128, 128, 128)
    std_floor: float = 1e-2
    output_names: Sequence[str] = field(default_factory=tuple)
    task_param_names: Sequence[str] = field(default_factory=tuple)
    prior: str = "auto"
    prior_basis: int = 0
    prior_clip: bool = True
    prior_choice: PriorChoice | None = None

    def __post_init__(self) -> None:
        self.n_outputs = check_positive_int("n_outputs", self.n_outputs)
        self.n_task_params = check_positive_int("n_task_params", self.n_task_params, minimum=0)
        self.encoder_widths = tuple(check_positive_int("encoder_widths", w) for w in self.encoder_widths)
        self.decoder_widths = tuple(check_positive_int("decoder_widths", w) for w in self.decoder_widths)
        if not self.encoder_widths or not self.decoder_widths:
            raise ValueError("encoder_widths/decoder_widths: expected at least one layer each")
        if not (self.std_floor > 0):
            raise ValueError(f"std_floor: expected > 0, got {self.std_floor}")
        self.output_names = tuple(str(s) for s in self.output_names) or tuple(
            f"y{i}" for i in range(self.n_outputs)
        )
        self.task_param_names = tuple(str(s) for s in self.task_param_names) or tuple(
            f"p{i}" for i in range(self.n_task_params)
        )
        if self.prior not in PRIORS:
            raise ValueError(f"prior: expected one of {', '.join(PRIORS)}, got {self.prior!r}")
        if isinstance(self.prior_choice, dict):
            self.prior_choice = PriorChoice.from_dict(self.prior_choice)
        self.prior_basis = check_positive_int("prior_basis", self.prior_basis, minimum=0)
        if self.prior_basis == 1:
            raise ValueError("prior_basis: expected 0 (chosen from the demonstrations) or at least 2, got 1")
        if len(self.output_names) != self.n_outputs:
            raise ValueError(f"output_names: expected {self.n_outputs} names, got {len(self.output_names)}")
        if len(self.task_param_names) != self.n_task_params:
            raise ValueError(
                f"task_param_names: expected {self.n_task_params} names, got {len(self.task_param_names)}"
            )

    @property
    def latent_dim(self) -> int:
        return self.encoder_widths[-1]

    @property
    def n_parameters(self) -> int:
        """Number of network parameters a :class:`CNMP` of this config has, computed from the
        widths without building it (so a service can refuse an absurd config before allocating)."""
        d, p = self.n_outputs, self.n_task_params

        def mlp(widths: Sequence[int], in_dim: int, out_dim: int | None) -> int:
            dims = [in_dim, *widths] + ([out_dim] if out_dim is not None else [])
            return sum(a * b + b for a, b in zip(dims, dims[1:]))

        return (mlp(self.encoder_widths, 1 + p + 2 * d, None)
                + mlp(self.decoder_widths, self.latent_dim + 1 + p, 2 * d))

    def to_dict(self) -> dict:
        """Plain types only, so a checkpoint loads with ``weights_only=True``."""
        d = asdict(self)
        d["prior_choice"] = None if self.prior_choice is None else self.prior_choice.to_dict()
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}

    @classmethod
    def from_dict(cls, d: dict) -> "CNMPConfig":
        """The config of :meth:`to_dict`'s map. A map written before the linear path existed (no
        ``prior`` key) is the paper's CNMP it described: ``prior = "none"``."""
        return cls(**{"prior": "none", **d})


def _mlp(widths: Sequence[int], in_dim: int, out_dim: int | None) -> nn.Sequential:
    layers: list[nn.Module] = []
    prev = in_dim
    for i, w in enumerate(widths):
        layers.append(nn.Linear(prev, w))
        # The encoder's last layer is the latent itself: no activation, so the mean is unconstrained.
        if out_dim is not None or i < len(widths) - 1:
            layers.append(nn.ReLU())
        prev = w
    if out_dim is not None:
        layers.append(nn.Linear(prev, out_dim))
    return nn.Sequential(*layers)


@dataclass
class Prediction:
    """A CNMP's answer in raw units.

    times (T,), mean (T, D), std (T, D), latent (L,); from :meth:`CNMP.predict_batch` the last three
    carry a leading batch axis B.
    """

    times: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    latent: np.ndarray


@dataclass
class Query:
    """Validated conditioning queries in normalised units, ready for the network.

    obs_x (B, N, 1+P+2D), obs_mask (B, N), tgt_x (B, T, 1+P); ``times`` (T,) raw query times
    shared by the B queries (B = 1 from :meth:`CNMP.make_query`).
    """

    obs_x: torch.Tensor
    obs_mask: torch.Tensor
    tgt_x: torch.Tensor
    times: np.ndarray


class CNMP(nn.Module):
    """A CNMP with built-in normalisation.

    Parameters
    ----------
    config : :class:`CNMPConfig`.
    seed : seeds the weight initialisation (the global torch RNG is left untouched).
    """

    def __init__(self, config: CNMPConfig, seed: int = 0) -> None:
        super().__init__()
        self.config = config
        d, p = config.n_outputs, config.n_task_params
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            self.encoder = _mlp(config.encoder_widths, 1 + p + 2 * d, None)
            self.decoder = _mlp(config.decoder_widths, config.latent_dim + 1 + p, 2 * d)
        self.time_norm = AffineNormalizer(1)
        self.task_norm = AffineNormalizer(p)
        self.value_norm = AffineNormalizer(d)
        self.register_buffer("fitted", torch.zeros((), dtype=torch.bool))
        # the linear path; with prior_basis 0 it is made when the model is fitted to demonstrations
        self.prior: LinearPrior | None = (LinearPrior(d, p, config.prior_basis)
                                          if config.prior in PATH_PRIORS and config.prior_basis else None)
        self._value_bounds: tuple[torch.Tensor, ...] | None = None

    def _load_from_state_dict(self, *args, **kwargs):
        self._value_bounds = None  # the normalisation changes: its bounds are read again
        super()._load_from_state_dict(*args, **kwargs)

    # ----- normalisation -------------------------------------------------------------------------
    def fit_normalization(self, demos: DemoSet) -> None:
        """Set the normalisation statistics from ``demos`` (raw units). Called once before training.
        A model whose prior is still "auto" is refused (ValueError): :func:`~.training.train` chooses
        it first."""
        if self.config.prior == "auto":
            raise ValueError('prior: "auto" is chosen when the model is trained (acnmp_core.model.training.train); '
                             'give "linear" or "none" to fit it without training')
        self._check_demos(demos)
        self.time_norm.fit(demos.all_times()[:, None], mode="range")
        self.task_norm.fit(demos.all_task_params(), mode="range")
        self.value_norm.fit(demos.all_values(), mode="standard")
        self.fitted.fill_(True)
        self._value_bounds = None
        if self.config.prior in PATH_PRIORS:
            self.fit_prior(demos)

    def fit_prior(self, demos: DemoSet) -> None:
        """Fit the linear path (``config.prior`` "linear" or "trend") on ``demos`` in this model's
        normalisation, choosing its basis count first when ``config.prior_basis`` is 0 (the config
        then records it). Called by :meth:`fit_normalization`."""
        packed = self.pack(demos)
        if not self.config.prior_basis:
            grid = torch.linspace(0.0, 1.0, 100, dtype=torch.float64)
            values = np.stack([np.stack([np.interp(grid.numpy(), packed.times[i, :n, 0].numpy(),
                                                   packed.values[i, :n, j].numpy())
                                         for j in range(self.config.n_outputs)], axis=1)
                               for i, n in enumerate(packed.lengths.tolist())])
            self.config.prior_basis, _ = choose_n_basis(np.tile(grid.numpy(), (len(values), 1)), values,
                                                        packed.task_params.numpy())
        self.prior = LinearPrior(self.config.n_outputs, self.config.n_task_params, self.config.prior_basis).fit(
            packed.times[..., 0].numpy(), packed.values.numpy(), packed.task_params.numpy(), packed.lengths.numpy())

    def pack(self, demos: DemoSet) -> PackedDemos:
        """Pad ``demos`` into normalised tensors for :class:`acnmp_core.model.episodes.EpisodeSampler`."""
        self._check_demos(demos)
        n, tmax, d = len(demos), max(len(x.times) for x in demos), self.config.n_outputs
        times = torch.zeros(n, tmax, 1, dtype=torch.float64)
        values = torch.zeros(n, tmax, d, dtype=torch.float64)
        lengths = torch.zeros(n, dtype=torch.int64)
        for i, demo in enumerate(demos):
            k = len(demo.times)
            times[i, :k, 0] = torch.from_numpy(np.array(demo.times))
            values[i, :k] = torch.from_numpy(np.array(demo.values))
            lengths[i] = k
        with torch.no_grad():
            return PackedDemos(
                times=self.time_norm.normalize(times),
                values=self.value_norm.normalize(values),
                task_params=self.task_norm.normalize(torch.as_tensor(demos.all_task_params())),
                lengths=lengths,
            )

    def _check_demos(self, demos: DemoSet) -> None:
        if demos.n_outputs != self.config.n_outputs:
            raise ValueError(f"demos: expected {self.config.n_outputs} output dims, got {demos.n_outputs}")
        if demos.n_task_params != self.config.n_task_params:
            raise ValueError(
                f"demos: expected {self.config.n_task_params} task parameters, got {demos.n_task_params}"
            )

    # ----- device ---------------------------------------------------------------------------------
    @property
    def device(self) -> torch.device:
        """Where the encoder and decoder run (acnmp_core/model/device.py)."""
        return next(self.encoder.parameters()).device

    def to_device(self, device: str | torch.device) -> "CNMP":
        """Move the encoder and decoder to ``device`` (``cpu``, ``cuda``, ``auto``:
        :func:`acnmp_core.model.device.resolve_device`), once; the normalisers stay on the CPU. Returns
        self. Make optimisers after the move (theirs are the parameters moved)."""
        from .device import resolve_device

        target = resolve_device(device)
        self.encoder.to(target)
        self.decoder.to(target)
        return self

    # ----- network -------------------------------------------------------------------------------
    def encode(self, obs_x: torch.Tensor, obs_mask: torch.Tensor) -> torch.Tensor:
        """Observations (B, N, 1+P+2D) with mask (B, N) -> latent (B, L), the masked mean; on the
        networks' device (inputs are moved there; a no-op on the CPU)."""
        device = self.device
        h = self.encoder(obs_x.to(device))
        m = obs_mask.to(device=device, dtype=h.dtype)[..., None]
        return (h * m).sum(1) / m.sum(1).clamp_min(1.0)

    def decode(self, latent: torch.Tensor, tgt_x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Latent (B, L) and targets (B, M, 1+P) -> mean, std (B, M, D) in normalised units."""
        r = latent[:, None, :].expand(-1, tgt_x.shape[1], -1)
        return self._head(torch.cat([r, tgt_x.to(latent.device)], dim=-1))

    def _head(self, dec_x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Decoder inputs (..., L+1+P) -> mean, std (..., D) in normalised units."""
        mean, raw = self.decoder(dec_x).chunk(2, dim=-1)
        return mean, self.config.std_floor + F.softplus(raw)

    def forward(self, obs_x, obs_mask, tgt_x):
        """(B,N,1+P+2D), (B,N), (B,M,1+P) -> mean (B,M,D), std (B,M,D), latent (B,L); normalised units.
        With a linear path the mean is that path plus the network's residual; with the trend, the
        network's answer to the clipped query plus the path's change beyond it (module docstring)."""
        net_obs = self.network_obs(obs_x)
        weights = self.path_weights(obs_x, net_obs, obs_mask)
        latent = self.encode(net_obs, obs_mask)
        mean, std = self.decode(latent, self.network_targets(tgt_x))
        return self._with_prior(mean, tgt_x, weights), std, latent

    def path_weights(self, obs_x: torch.Tensor, net_obs: torch.Tensor, obs_mask: torch.Tensor) -> np.ndarray | None:
        """The weights (B, D, K) of what the linear path adds to the network's mean for queries
        ``obs_x`` (B, N, 1+P+2D) whose network inputs are ``net_obs`` (:meth:`network_obs`), normalised
        units: "linear": the path's weights; "trend": the path's change from the clipped query to the
        query (None when nothing was clipped: inside the range the trend adds nothing); None without
        a linear path."""
        if self.config.prior != "trend":
            return self.prior_weights(obs_x, obs_mask)
        if self.prior is None or torch.equal(net_obs, obs_x):
            return None
        return self.prior_weights(obs_x, obs_mask) - self.prior_weights(net_obs, obs_mask)

    # ----- the linear path ---------------------------------------------------------------------
    def prior_weights(self, obs_x: torch.Tensor, obs_mask: torch.Tensor) -> np.ndarray | None:
        """The linear path's weights (B, D, K) for queries with observations (B, N, 1+P+2D) and mask
        (B, N), normalised units; None without a linear path. The path is conditioned on the task
        parameters, and on the observed points only in a skill without task parameters: the
        network then learns one residual per task parameters (what the path misses there), not one
        per set of observed points, which it could not tell apart from the points alone."""
        if self.prior is None:
            if self.config.prior in PATH_PRIORS and bool(self.fitted):
                raise ValueError("model: its linear path is not fitted; fit the model to demonstrations first")
            return None
        d, p = self.config.n_outputs, self.config.n_task_params
        x = obs_x.detach().cpu().numpy()
        if p:
            x = x[:, :0]  # no observations: the path of the task parameters alone
            return self.prior.condition(x[..., 0], x[..., 1 + p:1 + p + d], x[..., 1 + p + d:],
                                        np.zeros(x.shape[:2], dtype=bool), obs_x[:, 0, 1:1 + p].detach().cpu().numpy())[0]
        return self.prior.condition(x[..., 0], x[..., 1 + p:1 + p + d], x[..., 1 + p + d:], obs_mask.cpu().numpy(),
                                    x[:, 0, 1:1 + p])[0]

    def _bounds(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """The range the network was trained on, normalised (float32): task parameters' low and high
        (P,), values' low and high (D,); computed once per fit, load or widening."""
        if self._value_bounds is None:
            self._value_bounds = tuple(norm.normalize(b.to(torch.float64)).to(torch.float32)
                                       for norm in (self.task_norm, self.value_norm) for b in (norm.low, norm.high))
        return self._value_bounds

    def _clips(self) -> bool:
        """Whether the network sees its inputs clipped to its trained range: with the trend always,
        with the linear path as ``prior_clip`` says."""
        return self.prior is not None and (self.config.prior == "trend" or self.config.prior_clip)

    def network_obs(self, obs_x: torch.Tensor) -> torch.Tensor:
        """The encoder's observations: with a clipping linear path (:meth:`_clips`), their task
        parameters and values clipped to the range the network was trained on, so it never sees a
        condition beyond it (the path carries what lies beyond); else ``obs_x``."""
        if not self._clips():
            return obs_x
        d, p = self.config.n_outputs, self.config.n_task_params
        dims = obs_x[..., 1 + p + d:]
        p_lo, p_hi, lo, hi = (b.to(obs_x.device) for b in self._bounds())
        values = torch.maximum(torch.minimum(obs_x[..., 1 + p:1 + p + d], hi), lo) * dims
        params = torch.maximum(torch.minimum(obs_x[..., 1:1 + p], p_hi), p_lo)
        return torch.cat([obs_x[..., :1], params, values, dims], dim=-1)

    def network_targets(self, tgt_x: torch.Tensor) -> torch.Tensor:
        """The decoder's targets: with a clipping linear path, their task parameters clipped to the
        range the network was trained on; else ``tgt_x`` itself."""
        if not self._clips() or not self.config.n_task_params:
            return tgt_x
        p_lo, p_hi = (b.to(tgt_x.device) for b in self._bounds()[:2])
        return torch.cat([tgt_x[..., :1], torch.maximum(torch.minimum(tgt_x[..., 1:], p_hi), p_lo)], dim=-1)

    def follow_demos(self, demos: DemoSet) -> None:
        """Continued training on ``demos`` (the demonstrations and the solutions assimilated since),
        normalisation kept: the range the network sees widens to every one's (:meth:`widen_range`),
        so a solution beyond the first range is seen as it is, not as the old edge, and the linear
        path, if any, is fitted again on all of them (a solution joins its statistics as a
        demonstration), its basis count kept."""
        self._check_demos(demos)
        for demo in demos:
            self.widen_range(demo)
        if self.prior is not None:
            self.fit_prior(demos)

    def widen_range(self, demo) -> None:
        """Take a new demonstration's values (T, D) and task parameters (P,) (raw units) into the
        range the network is trained on (the normalisers' ``low`` and ``high``; their shift and
        scale, what the network's inputs mean, are kept): a solution assimilated beyond the
        demonstrations is then seen by the network as it is, not clipped to the old edge."""
        for norm, data in ((self.task_norm, np.asarray(demo.task_params, dtype=np.float64).reshape(1, -1)),
                           (self.value_norm, np.asarray(demo.values, dtype=np.float64))):
            if norm.dim:
                norm.low.copy_(torch.minimum(norm.low, torch.as_tensor(data.min(axis=0))))
                norm.high.copy_(torch.maximum(norm.high, torch.as_tensor(data.max(axis=0))))
        self._value_bounds = None

    def path_mean(self, query: Query) -> np.ndarray | None:
        """(T, D) the linear path alone for a prepared single :class:`Query`, raw units (None
        without a linear path)."""
        weights = self.prior_weights(query.obs_x, query.obs_mask)
        if weights is None:
            return None
        path = self.prior.path(query.tgt_x[..., 0].numpy().astype(np.float64), weights)[0]
        return self.value_norm.denormalize(torch.from_numpy(path)).numpy()

    def _with_prior(self, mean: torch.Tensor, tgt_x: torch.Tensor, weights: np.ndarray | None) -> torch.Tensor:
        """The network's mean (B, M, D) plus the linear path at the targets' times (unchanged without one)."""
        if weights is None:
            return mean
        path = self.prior.path(tgt_x[..., 0].detach().cpu().numpy(), weights)
        return mean + torch.from_numpy(path).to(mean.dtype).to(mean.device)

    # ----- conditioning API (raw units) ----------------------------------------------------------
    def make_query(
        self,
        obs_times,
        obs_values,
        task_params=None,
        query_times=None,
        *,
        n_steps: int | None = None,
        obs_dims_mask=None,
    ) -> Query:
        """Validate a conditioning request and turn it into network inputs.

        Parameters
        ----------
        obs_times : (N,) observation times, N >= 1, within the trained time range.
        obs_values : (N, D) observed values, raw units (entries masked out may be anything finite).
        task_params : (P,) task parameters, raw units; None allowed only when P == 0.
        query_times : (T,) times to predict at; or give ``n_steps`` for a uniform grid over the
            trained time range (not both: ValueError).
        obs_dims_mask : (N, D) bool, which output dimensions each observation carries (default all).

        Returns a :class:`Query`. Raises ValueError naming the argument on bad input.
        """
        if not bool(self.fitted):
            raise ValueError("model: normalisation is not fitted; train the model first")
        cfg = self.config
        d, p = cfg.n_outputs, cfg.n_task_params
        obs_times = check_array("obs_times", obs_times, ndim=1, min_size=1)
        n = obs_times.shape[0]
        obs_values = check_array("obs_values", obs_values, ndim=2, shape=(n, d))
        if obs_dims_mask is None:
            dims = np.ones((n, d))
        else:
            dims = check_array("obs_dims_mask", obs_dims_mask, shape=(n, d), dtype=bool).astype(np.float64)
            if np.any(dims.sum(axis=1) == 0):
                raise ValueError("obs_dims_mask: every observation must carry at least one output dimension")
        if task_params is None:
            if p:
                raise ValueError(f"task_params: expected {p} task parameters, got none")
            task_params = np.zeros(0)
        task_params = check_array("task_params", task_params, ndim=1, shape=(p,))
        if query_times is not None and n_steps is not None:
            raise ValueError("query_times and n_steps: give one of them (n_steps makes a uniform grid of "
                             "query times), not both")
        if query_times is None:
            if n_steps is None:
                raise ValueError("query_times: give query_times or n_steps")
            n_steps = check_positive_int("n_steps", n_steps, minimum=2)
            lo, hi = self.time_range()
            query_times = np.linspace(lo, hi, n_steps)
        query_times = check_array("query_times", query_times, ndim=1, min_size=1)
        self._check_times("obs_times", obs_times)
        self._check_times("query_times", query_times)
        return self._build_query(obs_times[None], obs_values[None], dims[None], task_params[None], query_times)

    def make_batch_query(self, obs_times, obs_values, task_params=None, query_times=None, *,
                         obs_dims_mask=None) -> Query:
        """Validate B conditioning requests that share N observations each and the query times.

        Parameters
        ----------
        obs_times : (B, N) observation times, within the trained time range.
        obs_values : (B, N, D) observed values, raw units.
        task_params : (B, P) task parameters, raw units; None allowed only when P == 0.
        query_times : (T,) times to predict at, the same for every request.
        obs_dims_mask : (B, N, D) bool, which output dimensions each observation carries (default all).

        Returns a :class:`Query` with batch dimension B. Raises ValueError naming the argument.
        """
        if not bool(self.fitted):
            raise ValueError("model: normalisation is not fitted; train the model first")
        d, p = self.config.n_outputs, self.config.n_task_params
        obs_times = check_array("obs_times", obs_times, ndim=2, min_size=1)
        b, n = obs_times.shape
        obs_values = check_array("obs_values", obs_values, shape=(b, n, d))
        if obs_dims_mask is None:
            dims = np.ones((b, n, d))
        else:
            dims = check_array("obs_dims_mask", obs_dims_mask, shape=(b, n, d), dtype=bool).astype(np.float64)
            if np.any(dims.sum(axis=2) == 0):
                raise ValueError("obs_dims_mask: every observation must carry at least one output dimension")
        if task_params is None:
            if p:
                raise ValueError(f"task_params: expected {p} task parameters per request, got none")
            task_params = np.zeros((b, 0))
        task_params = check_array("task_params", task_params, shape=(b, p))
        query_times = check_array("query_times", query_times, ndim=1, min_size=1)
        self._check_times("obs_times", obs_times)
        self._check_times("query_times", query_times)
        return self._build_query(obs_times, obs_values, dims, task_params, query_times)

    def _build_query(self, obs_times: np.ndarray, obs_values: np.ndarray, dims: np.ndarray, task_params: np.ndarray,
                     query_times: np.ndarray) -> Query:
        """Checked raw arrays (B, N), (B, N, D), (B, N, D), (B, P), (T,) -> normalised network inputs.

        In numpy rather than torch: on arrays this small, each torch call costs more than its
        arithmetic, and a predict is answered per request by the model service. Every operation is
        elementwise in float64 then rounded to float32 once, exactly as torch would compute it.
        """
        b, n = obs_times.shape
        p, t = task_params.shape[1], len(query_times)

        def norm(x: np.ndarray, normalizer: AffineNormalizer) -> np.ndarray:
            return (x - normalizer.shift.numpy()) / normalizer.scale.numpy()

        tn = norm(obs_times[..., None], self.time_norm)  # (B, N, 1)
        dm = np.asarray(dims, dtype=np.float64)
        vn = norm(obs_values, self.value_norm)
        pn = norm(task_params, self.task_norm)[:, None, :]  # (B, 1, P)
        obs_x = np.concatenate([tn, np.broadcast_to(pn, (b, n, p)), vn * dm, dm], axis=-1)
        qn = norm(query_times[:, None], self.time_norm)  # (T, 1)
        tgt_x = np.concatenate([np.broadcast_to(qn, (b, t, 1)), np.broadcast_to(pn, (b, t, p))], axis=-1)
        return Query(
            obs_x=torch.from_numpy(obs_x.astype(np.float32)),
            obs_mask=torch.ones(b, n, dtype=torch.bool),
            tgt_x=torch.from_numpy(tgt_x.astype(np.float32)),
            times=query_times,
        )

    def _check_times(self, name: str, times: np.ndarray) -> None:
        lo, hi = self.time_range()
        tol = TIME_RANGE_TOLERANCE * (hi - lo)
        if times.min() < lo - tol or times.max() > hi + tol:
            raise ValueError(
                f"{name}: expected times within the trained range [{lo:g}, {hi:g}], "
                f"got [{times.min():g}, {times.max():g}]"
            )

    def time_range(self) -> tuple[float, float]:
        """(t_min, t_max) of the training demonstrations, raw units."""
        lo, hi = self.time_norm.range_np()
        return float(lo[0]), float(hi[0])

    def predict_query(self, query: Query) -> Prediction:
        """Run a prepared :class:`Query` without gradients; returns raw units."""
        with torch.no_grad():
            mean, std, latent = self(query.obs_x, query.obs_mask, query.tgt_x)
            mean = self.value_norm.denormalize(mean[0].cpu().double())
            std = self.value_norm.denormalize_std(std[0].cpu().double())
        return Prediction(query.times.copy(), mean.numpy(), std.numpy(), latent[0].cpu().double().numpy())

    def predict_queries(self, queries: Sequence[Query]) -> list[Prediction]:
        """Several prepared single queries (B = 1 each, any N and T) in one forward pass.

        The observations of all queries go through the encoder as one (sum N, 1+P+2D) matrix, each
        query's latent is the mean of its own rows, and all targets go through the decoder as one
        (sum T, L+1+P) matrix: no padding, so the cost is that of the queries' points, and element i
        of the returned list (a :class:`Prediction` like :meth:`predict_query`'s, raw units) equals
        ``predict_query(queries[i])``: bit for bit for a single query, to float32 rounding for
        several (matrix kernels of a few rows sum in another order than those of many; see
        tests/unit/model/test_cnmp.py).
        """
        if len(queries) <= 1:  # alone: the plain path (fewer tensor operations, the same numbers)
            return [self.predict_query(q) for q in queries]
        n_obs = [q.obs_x.shape[1] for q in queries]
        n_tgt = [q.tgt_x.shape[1] for q in queries]
        device = self.device
        with torch.no_grad():
            net_obs = [self.network_obs(q.obs_x) for q in queries]
            weights = [self.path_weights(q.obs_x, o, q.obs_mask) for q, o in zip(queries, net_obs)]
            obs = [o[0] for o in net_obs]
            h = self.encoder(torch.cat(obs).to(device))
            # the same masked mean as encode() on each query (its mask is all ones)
            latents = [part.sum(0) / float(n) for part, n in zip(h.split(n_obs), n_obs)]
            r = torch.stack(latents).repeat_interleave(torch.tensor(n_tgt, device=device), dim=0)  # (sum T, L)
            mean, std = self._head(torch.cat([r, torch.cat([self.network_targets(q.tgt_x)[0] for q in queries]).to(device)],
                                             dim=-1))
            if self.prior is not None:
                mean = torch.cat([self._with_prior(m[None], q.tgt_x, w)[0]
                                  for m, q, w in zip(mean.split(n_tgt), queries, weights)])
            mean = self.value_norm.denormalize(mean.cpu().double())
            std = self.value_norm.denormalize_std(std.cpu().double())
        return [Prediction(q.times.copy(), m.numpy(), s.numpy(), lat.cpu().double().numpy())
                for q, m, s, lat in zip(queries, mean.split(n_tgt), std.split(n_tgt), latents)]

    def predict_batch(self, obs_times, obs_values, task_params=None, query_times=None, *,
                      obs_dims_mask=None) -> Prediction:
        """B queries in one forward pass; arguments as :meth:`make_batch_query`.

        Returns a :class:`Prediction` with a leading batch axis, raw units: times (T,),
        mean (B, T, D), std (B, T, D), latent (B, L). Row i equals :meth:`predict` on request i (up to
        float32 rounding in the batched matrix products).
        """
        q = self.make_batch_query(obs_times, obs_values, task_params, query_times, obs_dims_mask=obs_dims_mask)
        with torch.no_grad():
            mean, std, latent = self(q.obs_x, q.obs_mask, q.tgt_x)
            mean = self.value_norm.denormalize(mean.cpu().double())
            std = self.value_norm.denormalize_std(std.cpu().double())
        return Prediction(q.times.copy(), mean.numpy(), std.numpy(), latent.cpu().double().numpy())

    def predict(
        self,
        obs_times,
        obs_values,
        task_params=None,
        query_times=None,
        *,
        n_steps: int | None = None,
        obs_dims_mask=None,
    ) -> Prediction:
        """Condition on observations and task parameters; predict at ``query_times``.

        Same arguments as :meth:`make_query`. Returns a :class:`Prediction` (raw units): times (T,),
        mean (T, D), std (T, D), latent (L,). The model is not modified.
        """
        return self.predict_query(
            self.make_query(
                obs_times, obs_values, task_params, query_times, n_steps=n_steps, obs_dims_mask=obs_dims_mask
            )
        )

    def mean_normalized(self, query: Query) -> torch.Tensor:
        """Differentiable mean (T, D) in normalised units for a query (used by adaptation), on the
        CPU whatever the networks' device (the gradient flows back through the copy)."""
        mean, _, _ = self(query.obs_x, query.obs_mask, query.tgt_x)
        return mean[0].cpu()

    def encode_demo(self, times, values, task_params=None) -> np.ndarray:
        """Latent (L,) of a whole trajectory: times (T,), values (T, D) used as observations."""
        q = self.make_query(times, values, task_params, np.asarray(times, dtype=np.float64)[:1])
        with torch.no_grad():
            return self.encode(self.network_obs(q.obs_x), q.obs_mask)[0].cpu().double().numpy()
