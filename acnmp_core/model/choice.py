"""What the default model's choice measured (:class:`PriorChoice`), recorded in a skill's config."""
from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class PriorChoice:
    """What :func:`~acnmp_core.model.selection.choose_prior` chose and why.

    chosen : "linear" or "none". errors : candidate -> held-out error at the edges (normalised RMS;
    empty when nothing could be held out). folds : the held-out demonstrations' indices, one list
    per fold. reason : one line a user reads (``acnmp query info``, the learner's train event).
    """

    chosen: str
    errors: dict[str, float]
    folds: tuple[tuple[int, ...], ...]
    reason: str

    def to_dict(self) -> dict:
        """Plain types only (a checkpoint loads with ``weights_only=True``)."""
        d = asdict(self)
        d["folds"] = [list(f) for f in self.folds]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "PriorChoice":
        return cls(str(d["chosen"]), {str(k): float(v) for k, v in d["errors"].items()},
                   tuple(tuple(int(i) for i in f) for f in d["folds"]), str(d["reason"]))
