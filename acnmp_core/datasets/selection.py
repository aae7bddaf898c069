"""What of a dataset becomes the demonstrations: the trajectory's features, the task parameters,
the episodes and the time axis (:class:`Selection`), and :func:`select_demos`, which applies it.

Feature references are written as on the command line: ``NAME`` (every component), ``NAME[i]``
or ``NAME[i:j]`` (a slice of the components, Python's rules). A task parameter is a per-frame
feature at the episode's first or last frame (``NAME@first``, ``NAME@last``) or a per-episode
field (``NAME``).
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..data.demo_io import DemoArrays
from .episodes import DatasetEpisodes, DatasetError, Episode
from .resample import resample

_REF = re.compile(r"^(?P<name>[^\[\]@]+?)(?:\[(?P<a>-?\d*)(?P<colon>:)?(?P<b>-?\d*)\])?(?:@(?P<at>first|last))?$")

#: How an episode's time becomes the demonstrations' ``times``.
PHASES = ("normalized", "time")
#: Which rows of a feature with one row more than its episode's steps (Minari's observations) are kept.
ALIGNS = ("before", "after")


@dataclass(frozen=True)
class FeatureRef:
    """A feature and the slice of its components (``stop`` None: to the end)."""

    name: str
    start: int | None = None
    stop: int | None = None

    @property
    def text(self) -> str:
        if self.start is None and self.stop is None:
            return self.name
        return f"{self.name}[{'' if self.start is None else self.start}:{'' if self.stop is None else self.stop}]"

    def take(self, array: np.ndarray) -> np.ndarray:
        """The selected components of ``array`` (..., k)."""
        return array[..., slice(self.start, self.stop)]


@dataclass(frozen=True)
class TaskParamRef:
    """A task parameter source: a per-frame feature at ``at`` ("first" or "last"), or a
    per-episode field (``at`` None)."""

    ref: FeatureRef
    at: str | None = None

    @property
    def text(self) -> str:
        return self.ref.text + (f"@{self.at}" if self.at else "")


def parse_feature(text: str, *, task_param: bool = False) -> FeatureRef | TaskParamRef:
    """A :class:`FeatureRef` (or, with ``task_param``, a :class:`TaskParamRef`) from its text;
    ValueError naming the text when it is malformed."""
    m = _REF.match(text.strip())
    if not m or (m["at"] and not task_param):
        form = "NAME, NAME[i], NAME[i:j], with @first or @last for a per-frame feature" if task_param \
            else "NAME, NAME[i] or NAME[i:j]"
        raise ValueError(f"{text!r}: not a feature reference (expected {form})")
    a, b = m["a"], m["b"]
    if m["colon"]:
        ref = FeatureRef(m["name"], int(a) if a else None, int(b) if b else None)
    elif a:
        i = int(a)
        ref = FeatureRef(m["name"], i, i + 1 if i != -1 else None)
    else:
        ref = FeatureRef(m["name"])
    return TaskParamRef(ref, m["at"]) if task_param else ref


@dataclass(frozen=True)
class Selection:
    """What becomes the demonstrations.

    trajectory : the per-frame features concatenated into each row's values (D = the sum of
    their selected components). task_params : where each task parameter comes from (P = the sum
    of their components). episodes : the episode indices to keep (None: all). successful : keep
    only the episodes the dataset marks successful. phase : "normalized" (each episode's time
    mapped to [0, 1]: the default, what the project's skills use) or "time" (the dataset's own
    time from the episode's start: seconds for LeRobot, steps for Minari). time : the per-frame
    feature that holds the time (None: the format's own: ``timestamp`` for LeRobot, the step
    index for Minari). resample : rows per demonstration after linear interpolation over the
    phase (None: every episode keeps its own frames; different lengths are padded and marked
    with ``lengths``). align : for a trajectory feature with one row more than the episode has
    steps (its shortest per-frame feature: Minari's observations, T+1 rows against T actions, the
    reset state first): "before" keeps rows 0..T-1 (the state each step starts from), "after"
    rows 1..T (the state each step reaches: what a robot that tracks one row per step is
    commanded to); None keeps every row (the trajectory's features are cut to the shortest of them).
    """

    trajectory: tuple[FeatureRef, ...]
    task_params: tuple[TaskParamRef, ...] = ()
    episodes: tuple[int, ...] | None = None
    successful: bool = False
    phase: str = "normalized"
    time: str | None = None
    resample: int | None = None
    align: str | None = None

    def __post_init__(self) -> None:
        if not self.trajectory:
            raise ValueError("trajectory: expected at least one feature")
        if self.phase not in PHASES:
            raise ValueError(f"phase: expected one of {PHASES}, got {self.phase!r}")
        if self.align is not None and self.align not in ALIGNS:
            raise ValueError(f"align: expected one of {ALIGNS}, got {self.align!r}")
        if self.resample is not None and self.resample < 2:
            raise ValueError(f"resample: expected at least 2 rows, got {self.resample}")


def _names(data: DatasetEpisodes, ref: FeatureRef, k: int) -> list[str]:
    names = list(data.names.get(ref.name, ()))
    if len(names) != k:
        names = [f"{ref.name}[{i}]" for i in range(k)] if k > 1 else [ref.name]
    return list(np.asarray(names, dtype=object)[slice(ref.start, ref.stop)])


def _frame(data: DatasetEpisodes, ep: Episode, ref: FeatureRef) -> np.ndarray:
    """The selected components of a per-frame feature of ``ep`` (T, k), checked."""
    where = data.where(ref.name)
    if ref.name in data.ranks:
        raise DatasetError(where, f"has shape {data.ranks[ref.name]} per frame (expected a vector: one number "
                                  "or a 1-D array per frame)", ref.name)
    if ref.name not in ep.frames:
        known = sorted(data.episodes[0].frames) if data.episodes else []
        fields = sorted(data.episodes[0].fields) if data.episodes else []
        hint = " (it is a per-episode field: use it as a task parameter)" if ref.name in fields else ""
        raise DatasetError(where, f"no such per-frame feature{hint} (expected one of {', '.join(known) or 'none'})",
                           ref.name)
    arr = ref.take(ep.frames[ref.name])
    if arr.shape[1] == 0:
        raise DatasetError(where, f"the slice {ref.text} selects no component of its "
                                  f"{ep.frames[ref.name].shape[1]} (expected at least one)", ref.name)
    bad = ~np.isfinite(arr)
    if bad.any():
        k = int(np.argwhere(bad)[0][0])
        raise DatasetError(where, f"episode {ep.index} frame {k} holds NaN or inf (expected finite numbers)", ref.name)
    return arr


def _aligned(rows: np.ndarray, ep: Episode, align: str | None) -> np.ndarray:
    """``rows`` (T', k) of a feature of ``ep`` with the row before its first step or after its last
    dropped (``align`` "after" or "before") when it has one row more than the episode's steps."""
    steps = min(len(v) for v in ep.frames.values())
    if align is None or len(rows) != steps + 1:
        return rows
    return rows[1:] if align == "after" else rows[:-1]


def _param(data: DatasetEpisodes, ep: Episode, p: TaskParamRef) -> np.ndarray:
    if p.at is not None:
        rows = _frame(data, ep, p.ref)
        return rows[0 if p.at == "first" else -1]
    where = data.where(p.ref.name)
    if p.ref.name not in ep.fields:
        if p.ref.name in ep.frames:
            raise DatasetError(where, f"is per-frame (expected {p.ref.name}@first or {p.ref.name}@last)", p.ref.name)
        known = sorted(ep.fields)
        raise DatasetError(where, f"no such per-episode field in episode {ep.index} (expected one of "
                                  f"{', '.join(known) or 'none'}, or a per-frame feature with @first/@last)", p.ref.name)
    arr = p.ref.take(ep.fields[p.ref.name])
    if not np.isfinite(arr).all():
        raise DatasetError(where, f"episode {ep.index} holds NaN or inf (expected finite numbers)", p.ref.name)
    return arr


def select_demos(data: DatasetEpisodes, sel: Selection) -> DemoArrays:
    """The demonstrations ``sel`` makes of ``data``: values (N, T, D) from the trajectory's
    features (all cut to the shortest of them, e.g. Minari's observations to its actions), times
    (N, T) from the time feature (phase in [0, 1] by default), task_params (N, P), value_names
    and task_param_names from the features' component names. DatasetError (one line naming the
    file, the feature and what was expected) for an unknown feature or episode, a feature that
    is not a vector per frame, NaNs, an episode shorter than 2 frames, or nothing left."""
    by_index = {ep.index: ep for ep in data.episodes}
    if sel.episodes is not None:
        missing = [i for i in sel.episodes if i not in by_index]
        if missing:
            raise DatasetError(data.path, f"no episode {missing[0]} (expected indices among "
                                          f"{min(by_index, default=0)}..{max(by_index, default=-1)})")
        episodes = [by_index[i] for i in sel.episodes]
    else:
        episodes = list(data.episodes)
    if sel.successful:
        if any(ep.success is None for ep in episodes):
            raise DatasetError(data.path, "does not mark episodes successful (expected a success feature: "
                                          "LeRobot's next.success, Minari's infos/success, a bag's custom_data "
                                          "acnmp.success); drop --successful")
        episodes = [ep for ep in episodes if ep.success]
    if not episodes:
        raise DatasetError(data.path, "no episode left to make demonstrations of"
                           + (" (none is successful)" if sel.successful else "") + " (expected at least one)")
    rows, params = [], []
    for ep in episodes:
        parts = [_aligned(_frame(data, ep, ref), ep, sel.align) for ref in sel.trajectory]
        t = min(len(p) for p in parts)
        values = np.concatenate([p[:t] for p in parts], axis=1)
        clock = sel.time or data.time
        stamps = np.arange(t, dtype=np.float64) if clock is None else _frame(data, ep, FeatureRef(clock))[:t, 0]
        if t < 2:
            raise DatasetError(data.where(sel.trajectory[0].name), f"episode {ep.index} has {t} frame(s) (expected at "
                                                                   "least 2 to make a trajectory)", sel.trajectory[0].name)
        stamps = stamps - stamps[0]
        if np.any(np.diff(stamps) <= 0):
            raise DatasetError(data.where(clock or ""), f"episode {ep.index}: times not strictly increasing "
                                                        "(expected one frame after another)", clock)
        phase = stamps / stamps[-1] if sel.phase == "normalized" else stamps
        if sel.resample is not None:
            phase, values = resample(phase, values, sel.resample)
        rows.append((phase, values))
        params.append(np.concatenate([_param(data, ep, p) for p in sel.task_params]) if sel.task_params
                      else np.zeros(0))
    n, d, p = len(rows), rows[0][1].shape[1], len(params[0])
    if any(len(q) != p for q in params):
        raise DatasetError(data.path, "task parameters of different sizes across episodes (expected the same)")
    t = max(len(r[0]) for r in rows)
    times, values, lengths = np.zeros((n, t)), np.zeros((n, t, d)), np.zeros(n, dtype=np.int64)
    for i, (phase, vals) in enumerate(rows):
        k = len(phase)
        lengths[i] = k
        times[i, :k], values[i, :k] = phase, vals
        step = phase[-1] - phase[-2]
        times[i, k:] = phase[-1] + step * np.arange(1, t - k + 1)  # padding, kept increasing
        values[i, k:] = vals[-1]
    first = episodes[0]
    value_names = [n for ref in sel.trajectory for n in _names(data, ref, first.frames[ref.name].shape[1])]
    param_names = [n for q in sel.task_params for n in
                   _names(data, q.ref, (first.frames[q.ref.name] if q.at else first.fields[q.ref.name]).shape[-1])]
    return DemoArrays(times, values, np.stack(params) if p else np.zeros((n, 0)),
                      task_param_names=np.array(param_names, dtype=str) if p else None,
                      value_names=np.array(value_names, dtype=str),
                      lengths=None if np.all(lengths == t) else lengths)
