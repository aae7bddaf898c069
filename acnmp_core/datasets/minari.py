"""Minari datasets (HDF5 storage) read and written with h5py and json (minari itself is not needed).

The layout, as minari 0.5 writes it::

    DATASETS/<namespace>/namespace_metadata.json   one per namespace level ({} when bare)
    DATASETS/<dataset id>/data/metadata.json       dataset_id, minari_version, data_format "hdf5",
                                                   total_episodes, total_steps, observation_space and
                                                   action_space (Gymnasium spaces as JSON), ...
    DATASETS/<dataset id>/data/main_data.hdf5      a group episode_<i> per episode: observations
                                                   (T+1 rows; a group for a Dict space), actions,
                                                   rewards, terminations, truncations (T rows),
                                                   infos/<key> (T rows); attributes id, total_steps,
                                                   seed, options/<key>, and any episode metadata

DATASETS is ``$MINARI_DATASETS_PATH``, else ``~/.minari/datasets``; a dataset id is
``(namespace/)name(-vN)``. :func:`read_minari` reads every numeric per-step array of every
episode (named by its HDF5 path: ``observations``, ``observations/state``, ``actions``,
``rewards``, ``infos/success``) and its attributes as per-episode fields; :func:`write_minari`
writes roll-outs (one episode each).
"""
from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np

from .episodes import (DatasetEpisodes, DatasetError, Episode, RolloutEpisode, check_rollouts, new_directory,
                       rollout_names)

#: the minari release whose dataset layout this writes (minari checks it against those it reads)
MINARI_VERSION = "0.5.4"
_ID = re.compile(r"^(?:[-_\w][-_\w/]*[-_\w]+/)?[-_\w]+?(?:-v\d+)?$")
FIELD_PREFIX = "acnmp/"
#: the attribute of an HDF5 dataset that names its components (the exports write it on actions,
#: observations/state and observations/task_params; minari itself ignores it)
NAMES = "names"
#: the per-step infos that mark an episode successful (any step true), the first found
SUCCESS_INFOS = ("infos/success", "infos/is_success")


def datasets_root() -> Path:
    """Where minari keeps its datasets: ``$MINARI_DATASETS_PATH``, else ``~/.minari/datasets``."""
    return Path(os.environ.get("MINARI_DATASETS_PATH") or Path.home() / ".minari" / "datasets")


def dataset_dir(dataset: str | os.PathLike) -> Path:
    """The ``data`` directory of ``dataset``: a directory given as a path (the dataset's own, or
    its ``data``), else a dataset id under :func:`datasets_root`."""
    path = Path(dataset)
    for candidate in (path / "data", path):
        if (candidate / "metadata.json").is_file():
            return candidate
    return datasets_root() / str(dataset) / "data"


def _h5py():
    try:
        import h5py
    except ImportError:  # a dependency of the project; only a broken install lacks it
        raise DatasetError("h5py", "not installed (expected it with the project: pip install h5py)") from None
    return h5py


def read_minari(dataset: str | os.PathLike) -> DatasetEpisodes:
    """Every episode of the Minari dataset ``dataset`` (an id under :func:`datasets_root`, or a
    directory): its numeric per-step arrays by HDF5 path (observations have one row more than
    actions), the step index as the time, its attributes as per-episode fields, and success from
    ``infos/success`` or ``infos/is_success`` (any step) where the dataset has it. DatasetError when it is not a Minari
    HDF5 dataset."""
    data = dataset_dir(dataset)
    meta_path = data / "metadata.json"
    if not meta_path.is_file():
        raise DatasetError(dataset, f"not a Minari dataset (expected {meta_path})")
    try:
        meta = json.loads(meta_path.read_text())
    except (OSError, ValueError) as exc:
        raise DatasetError(meta_path, f"not readable as JSON ({exc})") from None
    if meta.get("data_format", "hdf5") != "hdf5":
        raise DatasetError(meta_path, f"data_format {meta.get('data_format')!r} (expected 'hdf5')")
    main = data / "main_data.hdf5"
    h5py = _h5py()
    episodes, ranks, names = [], {}, {}
    try:
        f = h5py.File(main, "r")
    except OSError as exc:
        raise DatasetError(main, f"not a readable HDF5 file ({exc})") from None
    with f:
        keys = sorted((k for k in f.keys() if k.startswith("episode_")), key=lambda k: int(k.split("_", 1)[1]))
        for key in keys:
            group = f[key]
            frames: dict[str, np.ndarray] = {}

            def visit(name, obj):
                if not isinstance(obj, h5py.Dataset):
                    return
                if obj.dtype.kind not in "fiub" or obj.ndim == 0:
                    ranks.setdefault(name, obj.shape[1:] if obj.ndim else ())
                elif obj.ndim > 2:
                    ranks.setdefault(name, obj.shape[1:])
                else:
                    arr = obj[()].astype(np.float64)
                    frames[name] = arr.reshape(len(arr), -1)
                    _name(names, name, obj.attrs.get(NAMES), frames[name].shape[1])

            group.visititems(visit)
            fields, labels = {}, {}
            for name, value in group.attrs.items():
                value = value.decode() if isinstance(value, bytes) else value
                if isinstance(value, str):
                    labels[name] = value
                else:
                    arr = np.asarray(value)
                    if arr.dtype.kind in "fiub":
                        fields[name] = arr.astype(np.float64).reshape(-1)
            if f"{FIELD_PREFIX}task_params" in fields:
                _name(names, f"{FIELD_PREFIX}task_params", group.attrs.get(f"{FIELD_PREFIX}task_param_names"),
                      len(fields[f"{FIELD_PREFIX}task_params"]))
            marks = [frames[k] for k in SUCCESS_INFOS if k in frames]
            success = bool(marks[0].any()) if marks else None
            episodes.append(Episode(int(key.split("_", 1)[1]), frames, fields, labels, success))
    out = DatasetEpisodes(str(data), "minari", episodes, None, names, ranks, catalog=str(main))
    out.files.update({name: str(main) for ep in episodes[:1] for name in (*ep.frames, *ep.fields, *ep.labels)})
    out.files.update({name: str(main) for name in ranks})
    return out


def _name(names: dict[str, tuple[str, ...]], feature: str, attr, width: int) -> None:
    """Keep the component names an HDF5 attribute gives ``feature`` (a list of ``width`` strings;
    anything else is ignored, as minari does)."""
    if feature in names or attr is None:
        return
    items = [v.decode() if isinstance(v, bytes) else v for v in np.asarray(attr).reshape(-1).tolist()]
    if len(items) == width and all(isinstance(v, str) for v in items):
        names[feature] = tuple(items)


def _box(shape: int) -> dict:
    """A Gymnasium Box(-inf, inf, (shape,), float64) as minari serialises it."""
    return {"type": "Box", "dtype": "float64", "shape": [shape], "low": [-np.inf] * shape, "high": [np.inf] * shape}


def write_minari(dataset_id: str, rollouts: list[RolloutEpisode], *, root: str | os.PathLike | None = None,
                 description: str | None = None) -> Path:
    """Write ``rollouts`` as the new Minari dataset ``dataset_id`` under ``root`` (default
    :func:`datasets_root`) and return its directory. Each roll-out of T steps is one episode:

    - observations, a Dict space: ``state`` (T+1, D) the values before each step (the previous
      command, the first row repeated; the last row the final command), ``phase`` (T+1, 1) their
      phase, ``task_params`` (T+1, P) when P > 0;
    - ``actions`` (T, D): the roll-out's trajectory (the commanded values, raw units);
    - ``rewards`` (T,), ``terminations`` (true on the last step of a successful roll-out),
      ``truncations`` (true on the last step of one that did not succeed), ``infos/success``;
    - attributes ``acnmp/job``, ``acnmp/method``, ``acnmp/skill``, ``acnmp/robot``, ``acnmp/task``,
      ``acnmp/rollout_index``, ``acnmp/success``, ``acnmp/return``, ``acnmp/task_params`` and
      ``acnmp/task_param_names``;
    - the attribute ``names`` of ``actions`` and ``observations/state`` (the skill's output
      names the roll-outs carry, else ``q0..``) and of ``observations/task_params`` (its
      task-parameter names, else ``task_params.0..``), which :func:`read_minari` reads back.

    Written in a temporary directory and renamed into place, so a failure leaves nothing but
    namespace files. DatasetError for a malformed id, a dataset that exists, or roll-outs that do
    not fit together."""
    base = Path(root) if root is not None else datasets_root()
    if not _ID.match(dataset_id) or dataset_id.startswith("/") or ".." in dataset_id:
        raise DatasetError(dataset_id, "not a Minari dataset id (expected (namespace/)name(-vN), e.g. acnmp/e1-v0)")
    target = base / dataset_id
    if target.exists():
        raise DatasetError(target, "already exists (expected a new dataset id)")
    d, p = check_rollouts(rollouts, str(target))
    names, param_names = rollout_names(rollouts, d, p)
    obs_space = {"type": "Dict", "subspaces": {"state": _box(d), "phase": _box(1), **({"task_params": _box(p)} if p else {})}}
    total = sum(r.steps for r in rollouts)
    h5py = _h5py()
    with new_directory(target) as tmp:
        data = tmp / "data"
        data.mkdir()
        with h5py.File(data / "main_data.hdf5", "w", track_order=True) as f:
            for i, r in enumerate(rollouts):
                g = f.create_group(f"episode_{i}")
                traj = np.asarray(r.trajectory, dtype=np.float64)
                obs = g.create_group("observations")
                obs.create_dataset("state", data=np.vstack([traj[:1], traj])).attrs[NAMES] = names
                obs.create_dataset("phase", data=np.r_[r.times[:1], r.times].reshape(-1, 1).astype(np.float64))
                if p:
                    obs.create_dataset("task_params", data=np.tile(np.asarray(r.task_params, np.float64),
                                                                   (r.steps + 1, 1))).attrs[NAMES] = param_names
                g.create_dataset("actions", data=traj).attrs[NAMES] = names
                g.create_dataset("rewards", data=np.asarray(r.reward, dtype=np.float64))
                end = np.zeros(r.steps, dtype=bool)
                end[-1] = True
                g.create_dataset("terminations", data=end & bool(r.success))
                g.create_dataset("truncations", data=end & (not r.success))
                g.create_group("infos").create_dataset("success", data=end & bool(r.success))
                g.attrs.update({"id": i, "total_steps": r.steps,
                                **{f"{FIELD_PREFIX}{k}": getattr(r, k) for k in ("job", "method", "skill", "robot", "task")},
                                f"{FIELD_PREFIX}rollout_index": int(r.rollout_index),
                                f"{FIELD_PREFIX}success": bool(r.success), f"{FIELD_PREFIX}return": float(r.ret),
                                f"{FIELD_PREFIX}task_params": np.asarray(r.task_params, dtype=np.float64)})
                if p:
                    g.attrs[f"{FIELD_PREFIX}task_param_names"] = param_names
        meta = {"total_episodes": len(rollouts), "total_steps": total, "data_format": "hdf5", "jpeg_encoding": False,
                "observation_space": json.dumps(obs_space), "action_space": json.dumps(_box(d)),
                "dataset_id": dataset_id, "minari_version": MINARI_VERSION, "algorithm_name": "acnmp",
                "author": ["acnmp"], "description": description or "roll-outs recorded by an ACNMP deployment",
                "dataset_size": round((data / "main_data.hdf5").stat().st_size / 1e6, 1)}
        (data / "metadata.json").write_text(json.dumps(meta))
    parts = dataset_id.split("/")[:-1]
    for k in range(1, len(parts) + 1):  # minari lists a namespace by this file
        marker = base.joinpath(*parts[:k]) / "namespace_metadata.json"
        if not marker.exists():
            marker.write_text("{}")
    return target
