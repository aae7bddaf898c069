"""The verdict of a peers comparison: per task and case, a method of ACNMP's against the best peer.

A *cell* is one task and case. In each, every method's runs are summarised (:class:`MethodCell`:
successes, the median and the mean of episodes to a first success) and the best peer chosen
(:func:`best_peer`: the most successes by rate, then the smallest median, the smallest mean,
the plan's order). A method meets the target in a cell (:class:`CellVerdict`) when it succeeds as
often as the best peer, its median is no larger (ties count; a censored median is beyond every
number) and its mean at most :data:`MEAN_RATIO` times the best peer's. The runs where it needs more
episodes than the best peer at the same seed (the same test position) are listed: a median over
a handful of seeds can hide them.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .config import OWN_METHODS, PeerRun, mean_episodes, median_episodes

#: the decided target's bound on the mean: at most this many times the best peer's
MEAN_RATIO = 1.5


@dataclass(frozen=True)
class MethodCell:
    """One method's runs in one cell. runs, successes : counts. median : episodes (inf when half
    of the runs or more are censored). mean : episodes, a censored run counting its budget;
    ``mean_censored`` then says it is a lower bound. episodes : seed -> episodes (a censored run:
    None)."""

    method: str
    runs: int
    successes: int
    median: float
    mean: float
    mean_censored: bool
    episodes: dict[int, int | None]

    @property
    def rate(self) -> float:
        """successes / runs."""
        return self.successes / self.runs

    @classmethod
    def of(cls, method: str, runs: Sequence[PeerRun]) -> "MethodCell":
        """The summary of ``method``'s ``runs`` (at least one)."""
        mean, censored = mean_episodes(list(runs))
        return cls(method, len(runs), int(sum(r.success for r in runs)), median_episodes(list(runs)), mean, censored,
                   {int(r.seed): (int(r.episodes) if r.success else None) for r in runs})


@dataclass(frozen=True)
class CellVerdict:
    """A method against the best peer in one cell.

    mine, best : their :class:`MethodCell`. more_than_best : the seeds both ran where ``mine``
    needs more episodes than ``best`` (a censored run needs more than any success; two censored
    runs tie). met_successes, met_median, met_mean : the three parts of the target; met : all.
    """

    task: str
    case: str
    mine: MethodCell
    best: MethodCell
    more_than_best: tuple[int, ...]

    @property
    def met_successes(self) -> bool:
        return self.mine.rate >= self.best.rate

    @property
    def met_median(self) -> bool:
        return self.mine.median <= self.best.median

    @property
    def met_mean(self) -> bool:
        return self.mine.mean <= MEAN_RATIO * self.best.mean

    @property
    def met(self) -> bool:
        return self.met_successes and self.met_median and self.met_mean


def best_peer(cells: Sequence[MethodCell]) -> MethodCell:
    """The best of ``cells`` (in the plan's order): the highest success rate, then the smallest
    median, then the smallest mean; a tie goes to the first."""
    return min(cells, key=lambda c: (-c.rate, c.median, c.mean))


def _more(a: int | None, b: int | None) -> bool:
    """Whether episodes ``a`` are more than ``b`` (None: censored, beyond every number)."""
    if a is None:
        return b is not None
    return b is not None and a > b


def cell_verdicts(runs: Sequence[PeerRun], method: str, tasks: Sequence[str], cases: Sequence[str],
                  methods: Sequence[str], own: Sequence[str] = OWN_METHODS) -> list[CellVerdict]:
    """``method`` against the best peer in every cell of ``runs`` where both ran, in the order of
    ``tasks`` and ``cases``. The peers are the ``methods`` (the plan's order, which breaks ties) not
    in ``own`` (ACNMP's methods and LfD only)."""
    out = []
    for task in tasks:
        for case in cases:
            here = [r for r in runs if (r.task, r.case) == (task, case)]
            mine = [r for r in here if r.method == method]
            peers = [MethodCell.of(m, [r for r in here if r.method == m]) for m in methods
                     if m not in own and m != method and any(r.method == m for r in here)]
            if not mine or not peers:
                continue
            me, best = MethodCell.of(method, mine), best_peer(peers)
            more = tuple(s for s in sorted(me.episodes) if s in best.episodes and _more(me.episodes[s], best.episodes[s]))
            out.append(CellVerdict(task, case, me, best, more))
    return out


def verdicts_of(result: dict, method: str) -> list[CellVerdict]:
    """:func:`cell_verdicts` of a result JSON (``run_peers``' or a merge's) for ``method``."""
    runs = [PeerRun.from_json(r) for r in result["runs"]]
    config = result["config"]
    return cell_verdicts(runs, method, config["tasks"], config["cases"], config["methods"])


def shown(episodes: float, budget: int) -> str:
    """A median or mean as a page shows it: "> budget" when it is infinite."""
    return f"> {budget}" if not np.isfinite(episodes) else f"{episodes:g}"
