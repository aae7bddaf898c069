"""The episodes of a dataset as the importers read them, the roll-outs as the exporters write
them (and the directory they write them in), and the one error every bad input raises."""
from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


class DatasetError(ValueError):
    """A dataset that cannot be used as asked: the message is one line naming the file, the
    feature (when one is at fault) and what was expected."""

    def __init__(self, path: str, what: str, feature: str | None = None) -> None:
        self.path, self.feature, self.what = str(path), feature, what
        super().__init__(f"{path}: " + (f"feature {feature!r}: " if feature else "") + what)


@dataclass
class Episode:
    """One episode as read from a dataset.

    index : the episode's index in the dataset. frames : per-frame features by name, each
    (T_name, k) float64 (a scalar feature is (T, 1); Minari's observations have one row more than
    its actions). fields : per-episode numeric fields by name, each (k,) float64. labels :
    per-episode text fields by name. success : whether the dataset marks the episode successful
    (None: it does not say).
    """

    index: int
    frames: dict[str, np.ndarray]
    fields: dict[str, np.ndarray] = field(default_factory=dict)
    labels: dict[str, str] = field(default_factory=dict)
    success: bool | None = None


@dataclass
class DatasetEpisodes:
    """Every episode of a dataset, with what is known of its features.

    path : the file or directory the messages name. format : "lerobot" or "minari". time :
    the per-frame feature that holds each frame's time (None: the frame's index, one step per
    frame). names : component names per feature (from the dataset, where it gives them).
    ranks : per-frame features that are not vectors (images, ...) with their per-frame shape,
    which no selection may use. files : the file each feature is read from, and catalog the file
    that lists the features (both for messages).
    """

    path: str
    format: str
    episodes: list[Episode]
    time: str | None
    names: dict[str, tuple[str, ...]] = field(default_factory=dict)
    ranks: dict[str, tuple[int, ...]] = field(default_factory=dict)
    files: dict[str, str] = field(default_factory=dict)
    catalog: str | None = None

    def where(self, feature: str) -> str:
        """The file that holds ``feature`` (for one the dataset lacks, the file that lists them)."""
        return self.files.get(feature, self.catalog or self.path)


@dataclass(frozen=True)
class RolloutEpisode:
    """One roll-out to export as an episode.

    times : (T,) each row's phase (or time). trajectory : (T, D) the commanded values in raw
    units (e.g. m, rad). reward : (T,) the per-step rewards. success, ret : the roll-out's
    success and return. task_params : (P,). job, method, skill, robot, task : what produced it
    (empty strings where the recording does not say). rollout_index : its index in its job.
    value_names (D,), task_param_names (P,) : the skill's names of the trajectory's columns and of
    the task parameters (empty where the recording does not say). wall_time : when it was
    recorded (s since the epoch; None where unknown).
    """

    times: np.ndarray
    trajectory: np.ndarray
    reward: np.ndarray
    success: bool
    ret: float
    task_params: np.ndarray
    job: str = ""
    method: str = ""
    skill: str = ""
    robot: str = ""
    task: str = ""
    rollout_index: int = 0
    value_names: tuple[str, ...] = ()
    task_param_names: tuple[str, ...] = ()
    wall_time: float | None = None

    @property
    def steps(self) -> int:
        return int(self.trajectory.shape[0])


def check_rollouts(rollouts: list[RolloutEpisode], where: str) -> tuple[int, int]:
    """(D, P) shared by every roll-out of ``rollouts``; DatasetError naming ``where`` when there
    are none, they differ in D or P, or one is shorter than 2 steps or holds a NaN."""
    if not rollouts:
        raise DatasetError(where, "no roll-out to export (expected at least one)")
    dims = {r.trajectory.shape[1] for r in rollouts}
    params = {len(r.task_params) for r in rollouts}
    if len(dims) > 1 or len(params) > 1:
        raise DatasetError(where, f"roll-outs of different dimensions {sorted(dims)} or task parameters "
                                  f"{sorted(params)} (expected one kind: choose one job)")
    for r in rollouts:
        if r.steps < 2 or len(r.times) != r.steps or len(r.reward) != r.steps:
            raise DatasetError(where, f"roll-out {r.job}/{r.rollout_index}: {r.steps} steps, {len(r.times)} times, "
                                      f"{len(r.reward)} rewards (expected at least 2 steps and one time and reward each)")
        if not (np.isfinite(r.trajectory).all() and np.isfinite(r.times).all()):
            raise DatasetError(where, f"roll-out {r.job}/{r.rollout_index}: a NaN or inf in its trajectory or times "
                                      "(expected finite numbers)")
    return dims.pop(), params.pop()


def rollout_names(rollouts: list[RolloutEpisode], d: int, p: int) -> tuple[list[str], list[str]]:
    """The names of the D trajectory columns and the P task parameters of ``rollouts`` (checked
    with :func:`check_rollouts`): the skill's, where every roll-out that carries names carries the
    same ones, else ``q0..`` and ``task_params.0..``."""

    def agreed(kind: str, count: int) -> list[str] | None:
        named = {getattr(r, kind) for r in rollouts if len(getattr(r, kind)) == count and count}
        return list(named.pop()) if len(named) == 1 else None

    return (agreed("value_names", d) or [f"q{i}" for i in range(d)],
            agreed("task_param_names", p) or [f"task_params.{i}" for i in range(p)])


@contextmanager
def new_directory(root: Path) -> Iterator[Path]:
    """``with new_directory(root) as tmp:`` write into ``tmp``, a temporary directory beside
    ``root``, renamed to ``root`` when the block ends (``root`` must be absent or an empty
    directory then), removed when it raises: a failed export leaves nothing."""
    root.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{root.name}.", dir=root.parent))
    try:
        yield tmp
        if root.exists():
            root.rmdir()
        os.replace(tmp, root)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
