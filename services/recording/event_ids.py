"""Which events a deployment's recording already holds, in memory O(publishers): zenoh-free.

An event is identified by its publisher (``"<zid>/<eid>"``, the zenoh entity global id of its
advanced publisher) and the sample's sequence number (services/recording/recorder.py
``event_id``). A publisher numbers its samples 0, 1, 2, ... and zenoh-ext delivers them in
order, but a restarted recorder also gets, from the publishers' caches, events that an earlier
file holds, and the ids read back from a file come in no particular order. So per publisher
:class:`SeenEvents` keeps

* a **mark**: every sequence number up to it is settled (recorded, or given up as missed);
* a few **runs** ``[lo, hi]`` above it, sorted, disjoint and not adjacent: numbers recorded
  beyond a gap (the gap: events not received, yet or ever);
* **lost**: numbers settled without being recorded.

With in-order delivery a publisher has no run, or one per gap. A publisher with more than
``max_runs`` runs gives up its oldest gap: the mark moves to the end of the first run and that
gap's numbers count as lost (an event of it arriving later is then taken for a duplicate).

``missed`` counts the events of each publisher that no file holds although a later one does
(gaps below the newest number seen, lost ones included). :meth:`to_json` / :meth:`from_json`
carry the state from one recorder to the next (the marks file beside each .rrd).
"""
from __future__ import annotations

import bisect
from dataclasses import dataclass, field
from pathlib import Path

#: Runs kept per publisher before its oldest gap is given up (a gap costs one run, whatever its size).
MAX_RUNS = 64


def marks_path(recording: str | Path) -> Path:
    """The marks file of a recording (the recorder's starting state, services/recording/recorder.py):
    ``<recording>.seen.json`` beside it."""
    recording = Path(recording)
    return recording.with_name(recording.name + ".seen.json")


@dataclass(frozen=True)
class IndexRanges:
    """Numbers (a job's roll-out indices) as sorted, disjoint, inclusive ``(lo, hi)`` ranges: what a
    recorder's status says its files hold of one job (services/recording/recorder.py, ``held``)."""

    ranges: tuple[tuple[int, int], ...] = ()

    def __contains__(self, index: object) -> bool:
        if isinstance(index, bool) or not isinstance(index, int):
            return False
        i = bisect.bisect_right(self.ranges, (index, float("inf")))
        return i > 0 and self.ranges[i - 1][0] <= index <= self.ranges[i - 1][1]

    @classmethod
    def everything(cls) -> "IndexRanges":
        """Every index (a learner that records nowhere has nothing to wait for)."""
        return cls(((0, 2**63 - 1),))

    @classmethod
    def from_wire(cls, value: object) -> "IndexRanges":
        """From ``[[lo, hi], ...]`` (sorted, disjoint, 0 <= lo <= hi); ValueError for anything else."""
        if not isinstance(value, list):
            raise ValueError(f"expected a list of [lo, hi] ranges, got {type(value).__name__}")
        out, above = [], -1
        for pair in value:
            if (not isinstance(pair, list) or len(pair) != 2
                    or not all(isinstance(x, int) and not isinstance(x, bool) for x in pair)
                    or not above < pair[0] <= pair[1]):
                raise ValueError(f"not a sorted, disjoint [lo, hi] range: {pair!r}")
            out.append((pair[0], pair[1]))
            above = pair[1]
        return cls(tuple(out))


def split_event_id(event_id: str) -> tuple[str, int]:
    """``"<zid>/<eid>/<sn>"`` -> (``"<zid>/<eid>"``, sn). ValueError for another shape."""
    publisher, sep, sn = event_id.rpartition("/")
    zid, _, eid = publisher.partition("/")
    if not sep or not zid or not eid or not sn.isdigit():
        raise ValueError(f"not an event id <zid>/<eid>/<sn>: {event_id!r}")
    return publisher, int(sn)


@dataclass
class _Publisher:
    """One publisher's state: numbers <= ``mark`` settled, ``runs`` (flat [lo0, hi0, lo1, hi1, ...],
    sorted) recorded above it, ``lost`` settled unrecorded."""

    mark: int = -1
    runs: list[int] = field(default_factory=list)
    lost: int = 0

    def has(self, sn: int) -> bool:
        if sn <= self.mark:
            return True
        i = bisect.bisect_right(self.runs, sn)
        return i % 2 == 1 or (i > 0 and self.runs[i - 1] == sn)  # inside [lo, hi], or hi itself

    def add(self, sn: int, max_runs: int) -> None:
        """Record ``sn`` (above the mark and in no run): extend or join the neighbouring runs (or
        the mark), or start a run; then give up the oldest gaps beyond ``max_runs`` runs."""
        runs = self.runs
        # sn is in no run and equals no bound, so i (the bounds below sn) is even: the run below
        # sn is runs[i-2:i], the one above runs[i:i+2]
        i = bisect.bisect_left(runs, sn)
        joins_below = sn - 1 == (runs[i - 1] if i else self.mark)
        joins_above = i < len(runs) and runs[i] == sn + 1
        if joins_below and joins_above:
            if i:  # the runs below and above become one
                del runs[i - 1:i + 1]
            else:  # the mark reaches the end of the first run
                self.mark = runs[1]
                del runs[0:2]
        elif joins_below:
            if i:
                runs[i - 1] = sn
            else:
                self.mark = sn
        elif joins_above:
            runs[i] = sn
        else:
            runs[i:i] = [sn, sn]
        while len(runs) > 2 * max_runs:  # give up the oldest gap
            lo, hi = runs.pop(0), runs.pop(0)
            self.lost += lo - self.mark - 1
            self.mark = hi

    def missed(self) -> int:
        """Numbers not recorded below the newest one recorded."""
        gaps, below = 0, self.mark
        for lo, hi in zip(self.runs[::2], self.runs[1::2]):
            gaps += lo - below - 1
            below = hi
        return self.lost + gaps


class SeenEvents:
    """The event ids a recording holds: :meth:`add` says whether an id is new (and records it);
    memory per publisher is a mark plus at most ``max_runs`` runs."""

    def __init__(self, max_runs: int = MAX_RUNS) -> None:
        if max_runs < 1:
            raise ValueError(f"max_runs: expected >= 1, got {max_runs}")
        self.max_runs = int(max_runs)
        self._pubs: dict[str, _Publisher] = {}

    def __contains__(self, event_id: str) -> bool:
        publisher, sn = split_event_id(event_id)
        state = self._pubs.get(publisher)
        return state is not None and state.has(sn)

    def add(self, event_id: str) -> bool:
        """Record ``event_id`` (``"<zid>/<eid>/<sn>"``); True if it was new, False if already held
        (or given up as lost). ValueError for a malformed id."""
        publisher, sn = split_event_id(event_id)
        state = self._pubs.setdefault(publisher, _Publisher())
        if state.has(sn):
            return False
        state.add(sn, self.max_runs)
        return True

    def update(self, event_ids) -> None:
        """:meth:`add` every id of an iterable (e.g. the ids read back from a file)."""
        for event_id in event_ids:
            self.add(event_id)

    def missed(self) -> int:
        """Events not held although a later one of the same publisher is (see the module docstring)."""
        return sum(p.missed() for p in self._pubs.values())

    def ranges(self, publisher: str) -> list[list[int]]:
        """The sequence numbers of ``publisher`` held (given-up gaps included), as sorted, disjoint
        ``[lo, hi]`` ranges ([] for a publisher never seen)."""
        state = self._pubs.get(publisher)
        if state is None:
            return []
        out = [[0, state.mark]] if state.mark >= 0 else []
        return out + [[lo, hi] for lo, hi in zip(state.runs[::2], state.runs[1::2])]

    def copy(self) -> "SeenEvents":
        """An independent copy (same ``max_runs``)."""
        return SeenEvents.from_json(self.to_json(), self.max_runs)

    def publishers(self) -> int:
        """Publishers seen."""
        return len(self._pubs)

    def to_json(self) -> dict:
        """A JSON-able copy: ``{publisher: [mark, [lo, hi, ...], lost]}``."""
        return {k: [p.mark, list(p.runs), p.lost] for k, p in self._pubs.items()}

    @classmethod
    def from_json(cls, data: dict, max_runs: int = MAX_RUNS) -> "SeenEvents":
        """The inverse of :meth:`to_json`; ValueError if ``data`` is not of that shape."""
        seen = cls(max_runs)
        try:
            for publisher, (mark, runs, lost) in data.items():
                runs = [int(x) for x in runs]
                if len(runs) % 2 or runs != sorted(runs) or (runs and runs[0] <= int(mark) + 1):
                    raise ValueError(f"runs of {publisher!r} out of order: {runs}")
                seen._pubs[str(publisher)] = _Publisher(int(mark), runs, int(lost))
        except (TypeError, AttributeError) as exc:
            raise ValueError(f"not a SeenEvents state: {exc}") from None
        return seen
