"""What a paired skill's training is asked for and what it gives back: :class:`TransferConfig` (its
settings, validated) and :class:`PairTrainResult` (its per-step losses); torch-free, so a job's
request is checked without importing the networks (acnmp_core/transfer/pair.py trains them)."""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from typing import TYPE_CHECKING, Any

from ..errors import InputError
from ..validation import check_positive_int, check_type

if TYPE_CHECKING:
    from ..model.training import TrainConfig


@dataclass
class TransferConfig:
    """Training of a :class:`TransferPair`.

    latent_weight : weight of the latent alignment term (the authors': 5e6); 0 trains the two CNMPs
        independently (the "no alignment" control).
    steps : gradient steps. batch_size : paired episodes per step (the authors: 1).
    min_obs, max_obs : observations per episode, uniform in [min_obs, max_obs] (the authors' 9..12).
    n_targets : target points per episode. lr : Adam learning rate.
    widths : hidden widths of every encoder and decoder; the last is the latent size L.
    """

    latent_weight: float = 5e6
    steps: int = 3000
    batch_size: int = 16
    min_obs: int = 9
    max_obs: int = 12
    n_targets: int = 10
    lr: float = 1e-3
    widths: tuple[int, ...] = (128, 128, 128)

    def __post_init__(self) -> None:
        check_positive_int("steps", self.steps, minimum=0)
        for name in ("batch_size", "min_obs", "max_obs", "n_targets"):
            check_positive_int(name, getattr(self, name))
        if self.max_obs < self.min_obs:
            raise ValueError(f"max_obs: expected >= min_obs ({self.min_obs}), got {self.max_obs}")
        if not (self.latent_weight >= 0) or not math.isfinite(self.latent_weight):
            raise ValueError(f"latent_weight: expected a finite number >= 0, got {self.latent_weight}")
        if not (self.lr > 0):
            raise ValueError(f"lr: expected > 0, got {self.lr}")
        self.widths = tuple(check_positive_int("widths", w) for w in self.widths)

    def to_dict(self) -> dict:
        """Plain JSON-ready dict of every field."""
        d = asdict(self)
        d["widths"] = list(self.widths)
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "TransferConfig":
        """Inverse of :meth:`to_dict`: any subset of the fields (the rest take their defaults).
        An unknown field or an invalid value raises :class:`~acnmp_core.errors.InputError`."""
        check_type("config", d, Mapping)
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise InputError(f"config: unknown setting(s) {unknown}; allowed: {sorted(names)}")
        values = dict(d)
        if "widths" in values:
            check_type("config.widths", values["widths"], (list, tuple))
            values["widths"] = tuple(values["widths"])
        try:
            return cls(**values)
        except (TypeError, ValueError) as exc:
            raise InputError(f"config: {exc}") from None

    def sampling(self) -> TrainConfig:
        """The episode sampling of this config as a :class:`TrainConfig` (full observations only)."""
        from ..model.training import TrainConfig

        return TrainConfig(batch_size=self.batch_size, min_obs=self.min_obs, max_obs=self.max_obs,
                           n_targets=self.n_targets, lr=self.lr, partial_obs_prob=0.0)


@dataclass
class PairTrainResult:
    """Per-step losses of :func:`train_pair`: NLL of A's and B's decoders (normalised units) and
    the latent alignment MSE (unweighted)."""

    nll_a: list[float] = field(default_factory=list)
    nll_b: list[float] = field(default_factory=list)
    align: list[float] = field(default_factory=list)
