"""LeRobotDataset v3 read and written with pyarrow and json (lerobot itself is not needed).

The layout (``codebase_version`` "v3.0"), as lerobot writes it::

    ROOT/meta/info.json                       fps, features {name: {dtype, shape, names}}, totals, paths
    ROOT/meta/episodes/chunk-000/file-000.parquet   one row per episode: episode_index, tasks,
                                              length, data/chunk_index, data/file_index,
                                              dataset_from_index, dataset_to_index, ...
    ROOT/meta/tasks.parquet                   task_index, indexed by the task's text
    ROOT/meta/stats.json                      min, max, mean, std, count, q01..q99 per feature
    ROOT/data/chunk-000/file-000.parquet      one row per frame: every feature, timestamp,
                                              frame_index, episode_index, index, task_index

A feature of shape (1,) is a plain column, (k,) a fixed-size list; images and videos are
listed but are not vectors, so they cannot be a trajectory. :func:`read_lerobot` reads every
numeric vector feature per episode and every numeric or text column of the episodes table as a
per-episode field; :func:`write_lerobot` writes roll-outs (one episode each);
:func:`import_lerobot` imports lerobot's own reader where it is installed.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from .episodes import (DatasetEpisodes, DatasetError, Episode, RolloutEpisode, check_rollouts, new_directory,
                       rollout_names)

CODEBASE_VERSION = "v3.0"
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
EPISODES_PATH = "meta/episodes/chunk-000/file-000.parquet"
_NUMERIC = ("float16", "float32", "float64", "int8", "int16", "int32", "int64", "uint8", "uint16", "uint32", "bool")
#: columns of the episodes table that describe where an episode lies, not the episode
_LAYOUT = ("episode_index", "length", "dataset_from_index", "dataset_to_index")
_LAYOUT_PREFIXES = ("data/", "meta/", "stats/", "videos/")
#: the per-episode fields the exporter adds (also per-frame where a learner needs them)
FIELD_PREFIX = "acnmp/"


def _names(spec) -> tuple[str, ...]:
    names = spec.get("names")
    if isinstance(names, dict):  # e.g. {"motors": [...]}: the one list of names it holds
        lists = [v for v in names.values() if isinstance(v, list)]
        names = lists[0] if len(lists) == 1 else None
    return tuple(str(n) for n in names) if isinstance(names, list) else ()


def _column(table: pa.Table, name: str, width: int) -> np.ndarray:
    """A frame column as (rows, width) float64 (a fixed-size or variable list, or a scalar)."""
    col = table.column(name).combine_chunks()
    if pa.types.is_list(col.type) or pa.types.is_fixed_size_list(col.type) or pa.types.is_large_list(col.type):
        flat = col.flatten().to_numpy(zero_copy_only=False).astype(np.float64)
        return flat.reshape(len(col), -1) if len(col) else np.zeros((0, width))
    return col.to_numpy(zero_copy_only=False).astype(np.float64).reshape(-1, 1)


def read_lerobot(root: str | os.PathLike) -> DatasetEpisodes:
    """Every episode of the LeRobot v3 dataset at ``root`` (a local directory, e.g. a hub dataset
    already downloaded): its numeric vector features per frame, ``timestamp`` as the time, the
    numeric and text columns of the episodes table as per-episode fields, and success from
    ``next.success`` (any frame) where the dataset has it. DatasetError when ``root`` is not a
    v3 dataset or its files disagree with ``meta/info.json``."""
    root = Path(root)
    info_path = root / "meta" / "info.json"
    if not info_path.is_file():
        raise DatasetError(root, "not a LeRobot dataset (expected a directory with meta/info.json)")
    try:
        info = json.loads(info_path.read_text())
        features = dict(info["features"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise DatasetError(info_path, f"not a readable LeRobot info.json ({exc}; expected JSON with 'features')") from None
    version = str(info.get("codebase_version", ""))
    if not version.startswith("v3"):
        raise DatasetError(info_path, f"codebase_version {version or 'missing'} (expected v3.x: convert an older "
                                      "dataset with lerobot's convert_dataset_v21_to_v30)")
    files = sorted(root.glob("data/*/*.parquet"))
    if not files:
        raise DatasetError(root / "data", "no frames (expected data/chunk-*/file-*.parquet)")
    vectors, ranks, names = {}, {}, {}
    for name, spec in features.items():
        shape = tuple(spec.get("shape") or ())
        if spec.get("dtype") in _NUMERIC and len(shape) == 1:
            vectors[name] = shape[0]
            names[name] = _names(spec)
        else:
            ranks[name] = shape
    for name in ("episode_index", "timestamp"):
        if name not in vectors:
            raise DatasetError(info_path, "not among the features (expected in every LeRobot dataset)", name)
    data_where = str(files[0]) if len(files) == 1 else str(root / "data")
    try:
        tables = [pq.read_table(f, columns=list(vectors)) for f in files]
    except (pa.ArrowInvalid, OSError, KeyError) as exc:
        raise DatasetError(data_where, f"frames unreadable or missing a feature info.json lists ({exc})") from None
    table = pa.concat_tables(tables, promote_options="default") if len(tables) > 1 else tables[0]
    order_keys = [("episode_index", "ascending")] + ([("frame_index", "ascending")] if "frame_index" in vectors else [])
    table = table.sort_by(order_keys)
    ep_ids = table.column("episode_index").to_numpy(zero_copy_only=False)
    columns = {}
    for name, width in vectors.items():
        arr = _column(table, name, width)
        if arr.shape[1] != width:
            raise DatasetError(data_where, f"{arr.shape[1]} components per frame (expected {width} as "
                                           "meta/info.json says)", name)
        columns[name] = arr
    cuts = np.flatnonzero(np.diff(ep_ids)) + 1
    starts, stops = np.r_[0, cuts], np.r_[cuts, len(ep_ids)]
    meta = _episode_table(root)
    episodes = []
    for a, b in zip(starts, stops):
        index = int(ep_ids[a])
        frames = {name: columns[name][a:b] for name in columns}
        fields, labels = meta.get(index, ({}, {}))
        success = bool(frames["next.success"].any()) if "next.success" in frames else None
        episodes.append(Episode(index, frames, fields, labels, success))
    if "observation.task_params" in names:  # the exports' per-episode copy of the task parameters
        names[f"{FIELD_PREFIX}task_params"] = names["observation.task_params"]
    data = DatasetEpisodes(str(root), "lerobot", episodes, "timestamp", names, ranks, catalog=str(info_path))
    data.files.update({name: data_where for name in features})
    if meta:
        data.files.update({name: str(root / EPISODES_PATH) for fields, labels in meta.values() for name in (*fields, *labels)})
    return data


def _episode_table(root: Path) -> dict[int, tuple[dict[str, np.ndarray], dict[str, str]]]:
    """{episode_index: (numeric fields, text fields)} from meta/episodes (empty when absent)."""
    files = sorted(root.glob("meta/episodes/*/*.parquet"))
    out: dict[int, tuple[dict, dict]] = {}
    for f in files:
        try:
            schema = pq.read_schema(f)
            keep = [n for n in schema.names if n == "episode_index" or (n not in _LAYOUT and not n.startswith(_LAYOUT_PREFIXES))]
            rows = pq.read_table(f, columns=keep).to_pylist()
        except (pa.ArrowInvalid, OSError) as exc:
            raise DatasetError(f, f"not a readable episodes table ({exc})") from None
        for row in rows:
            fields, labels = {}, {}
            for key, value in row.items():
                if key == "episode_index" or value is None:
                    continue
                if isinstance(value, str):
                    labels[key] = value
                elif isinstance(value, list) and all(isinstance(v, str) for v in value):
                    labels[key] = ", ".join(value)
                elif isinstance(value, (bool, int, float)):
                    fields[key] = np.array([float(value)])
                elif isinstance(value, list) and all(isinstance(v, (bool, int, float)) for v in value):
                    fields[key] = np.asarray(value, dtype=np.float64)
            out[int(row["episode_index"])] = (fields, labels)
    return out


def _stats(arr: np.ndarray) -> dict[str, list]:
    """LeRobot's per-feature statistics of ``arr`` (frames, k)."""
    qs = np.quantile(arr, [0.01, 0.10, 0.50, 0.90, 0.99], axis=0) if len(arr) else np.zeros((5, arr.shape[1]))
    stats = {"min": arr.min(axis=0), "max": arr.max(axis=0), "mean": arr.mean(axis=0), "std": arr.std(axis=0)}
    out = {k: np.asarray(v, dtype=np.float64).tolist() for k, v in stats.items()}
    out["count"] = [int(len(arr))]
    out.update({f"q{q:02d}": qs[i].tolist() for i, q in enumerate((1, 10, 50, 90, 99))})
    return out


def write_lerobot(root: str | os.PathLike, rollouts: list[RolloutEpisode], *, fps: int = 10,
                  robot_type: str | None = None, value_names: list[str] | None = None) -> Path:
    """Write ``rollouts`` as a new LeRobot v3 dataset at ``root`` (which must not exist, or be an
    empty directory) and return its path. Each roll-out is one episode of T frames:

    - ``action`` (D,) float64: the roll-out's trajectory row (the commanded values, raw units);
    - ``observation.state`` (D,) float64: the values before that step (the previous command, the
      first row repeated), what a position-controlled robot that tracks its commands reports;
    - ``observation.phase`` (1,) float64: the row's phase (the recorded ``times``);
    - ``observation.task_params`` (P,) float64 (when P > 0): the task parameters, every frame;
    - the components named (``names`` in ``meta/info.json``) by the skill's output and
      task-parameter names the roll-outs carry (``value_names`` overrides the first), else
      ``q0..`` and ``task_params.0..``;
    - ``next.reward`` (1,) float64 per step, ``next.success`` and ``next.done`` (bool, true on
      the last frame, success only when the roll-out succeeded);
    - ``timestamp`` frame_index / ``fps`` s, and LeRobot's indices.

    The episodes table holds per episode ``acnmp/job``, ``acnmp/method``, ``acnmp/skill``,
    ``acnmp/robot``, ``acnmp/task`` (text), ``acnmp/rollout_index``, ``acnmp/success``,
    ``acnmp/return`` and ``acnmp/task_params`` (P,); the task's text is the task's name. The
    dataset is written in a temporary directory beside ``root`` and renamed into place, so a
    failure leaves nothing. DatasetError for roll-outs that do not fit together (see
    :func:`~.episodes.check_rollouts`) or a ``root`` that is not new."""
    root = Path(root)
    if root.exists() and (not root.is_dir() or any(root.iterdir())):
        raise DatasetError(root, "already exists (expected a new or empty directory for the dataset)")
    if fps < 1:
        raise DatasetError(root, f"fps {fps} (expected a positive integer)")
    d, p = check_rollouts(rollouts, str(root))
    names, param_names = rollout_names(rollouts, d, p)
    if value_names and len(value_names) == d:
        names = list(value_names)
    tasks = sorted({r.task or r.skill or "acnmp" for r in rollouts})
    task_index = {t: i for i, t in enumerate(tasks)}
    lengths = np.array([r.steps for r in rollouts])
    starts = np.r_[0, np.cumsum(lengths)[:-1]]
    total = int(lengths.sum())
    traj = np.concatenate([r.trajectory for r in rollouts])
    state = np.concatenate([np.vstack([r.trajectory[:1], r.trajectory[:-1]]) for r in rollouts])
    frame_index = np.concatenate([np.arange(n) for n in lengths])
    last = frame_index == np.repeat(lengths - 1, lengths)
    success = np.repeat([bool(r.success) for r in rollouts], lengths) & last
    columns = {
        "action": traj, "observation.state": state,
        "observation.phase": np.concatenate([r.times for r in rollouts]).astype(np.float64),
        **({"observation.task_params": np.repeat(np.stack([r.task_params for r in rollouts]), lengths, axis=0)} if p else {}),
        "next.reward": np.concatenate([r.reward for r in rollouts]).astype(np.float64),
        "next.success": success, "next.done": last,
        "timestamp": (frame_index / fps).astype(np.float32),
        "frame_index": frame_index.astype(np.int64),
        "episode_index": np.repeat(np.arange(len(rollouts)), lengths).astype(np.int64),
        "index": np.arange(total, dtype=np.int64),
        "task_index": np.repeat([task_index[r.task or r.skill or "acnmp"] for r in rollouts], lengths).astype(np.int64),
    }
    features: dict[str, dict] = {}
    arrays: dict[str, pa.Array] = {}
    for name, arr in columns.items():
        dtype = "bool" if arr.dtype == bool else str(arr.dtype)
        width = 1 if arr.ndim == 1 else arr.shape[1]
        col_names = {"action": names, "observation.state": names,
                     "observation.task_params": param_names}.get(name)
        features[name] = {"dtype": dtype, "shape": [width], "names": col_names}
        if arr.ndim == 1 or width == 1:
            arrays[name] = pa.array(arr.reshape(-1))
        else:
            arrays[name] = pa.FixedSizeListArray.from_arrays(pa.array(arr.reshape(-1)), width)
    hf = {"info": {"features": {name: ({"dtype": f["dtype"], "_type": "Value"} if f["shape"] == [1] else
                                       {"feature": {"dtype": f["dtype"], "_type": "Value"}, "length": f["shape"][0],
                                        "_type": "List"}) for name, f in features.items()}}}
    data = pa.table(arrays).replace_schema_metadata({"huggingface": json.dumps(hf)})
    episodes = pa.table({
        "episode_index": pa.array(np.arange(len(rollouts)), pa.int64()),
        "tasks": pa.array([[r.task or r.skill or "acnmp"] for r in rollouts], pa.list_(pa.string())),
        "length": pa.array(lengths, pa.int64()),
        "data/chunk_index": pa.array(np.zeros(len(rollouts)), pa.int64()),
        "data/file_index": pa.array(np.zeros(len(rollouts)), pa.int64()),
        "dataset_from_index": pa.array(starts, pa.int64()),
        "dataset_to_index": pa.array(starts + lengths, pa.int64()),
        **{f"{FIELD_PREFIX}{k}": pa.array([getattr(r, k) for r in rollouts], pa.string())
           for k in ("job", "method", "skill", "robot", "task")},
        f"{FIELD_PREFIX}rollout_index": pa.array([int(r.rollout_index) for r in rollouts], pa.int64()),
        f"{FIELD_PREFIX}success": pa.array([bool(r.success) for r in rollouts], pa.bool_()),
        f"{FIELD_PREFIX}return": pa.array([float(r.ret) for r in rollouts], pa.float64()),
        f"{FIELD_PREFIX}task_params": pa.array([np.asarray(r.task_params, dtype=np.float64).tolist() for r in rollouts],
                                               pa.list_(pa.float64())),
        "meta/episodes/chunk_index": pa.array(np.zeros(len(rollouts)), pa.int64()),
        "meta/episodes/file_index": pa.array(np.zeros(len(rollouts)), pa.int64()),
    })
    task_table = pa.table({"task_index": pa.array(range(len(tasks)), pa.int64()),
                           "__index_level_0__": pa.array(tasks, pa.string())})
    task_table = task_table.replace_schema_metadata({"pandas": json.dumps({  # so pandas indexes tasks by text
        "index_columns": ["__index_level_0__"],
        "column_indexes": [{"name": None, "field_name": None, "pandas_type": "unicode", "numpy_type": "object",
                            "metadata": {"encoding": "UTF-8"}}],
        "columns": [{"name": "task_index", "field_name": "task_index", "pandas_type": "int64", "numpy_type": "int64",
                     "metadata": None},
                    {"name": None, "field_name": "__index_level_0__", "pandas_type": "unicode", "numpy_type": "object",
                     "metadata": None}],
        "attributes": {}, "creator": {"library": "pyarrow", "version": pa.__version__}, "pandas_version": "2.2.0"})})
    info = {"codebase_version": CODEBASE_VERSION, "robot_type": robot_type, "total_episodes": len(rollouts),
            "total_frames": total, "total_tasks": len(tasks), "chunks_size": 1000, "data_files_size_in_mb": 100,
            "video_files_size_in_mb": 200, "fps": int(fps), "splits": {"train": f"0:{len(rollouts)}"},
            "data_path": DATA_PATH, "video_path": None, "features": features}
    stats = {name: _stats(np.asarray(arr, dtype=np.float64).reshape(total, -1)) for name, arr in columns.items()}
    with new_directory(root) as tmp:
        (tmp / "meta" / "episodes" / "chunk-000").mkdir(parents=True)
        (tmp / "data" / "chunk-000").mkdir(parents=True)
        pq.write_table(data, tmp / DATA_PATH.format(chunk_index=0, file_index=0), compression="snappy")
        pq.write_table(episodes, tmp / EPISODES_PATH, compression="snappy")
        pq.write_table(task_table, tmp / "meta" / "tasks.parquet")
        (tmp / "meta" / "info.json").write_text(json.dumps(info, indent=4))
        (tmp / "meta" / "stats.json").write_text(json.dumps(stats, indent=4))
    return root


def import_lerobot():
    """The format's own library, to check that it reads what :func:`write_lerobot` writes (the
    benchmark and the tests do; nothing here needs it): lerobot-dataset's modules as a namespace: ``lerobot_dataset`` (LeRobotDataset) and ``utils``
    (validate_frame, DEFAULT_FEATURES). ImportError when it is not installed (the ``datasets``
    extra).

    lerobot imports torchvision at module level, for images and videos only. PyPI's torchvision
    for this machine's CPU build of torch is a CUDA build that does not load beside it, so when
    torchvision cannot be imported a stand-in module is registered: the datasets exported here
    have no image or video features, and nothing of torchvision runs for them."""
    import importlib
    import sys
    import types

    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    try:
        import torchvision  # noqa: F401
    except Exception:
        for name in [m for m in sys.modules if m.startswith("torchvision")]:
            del sys.modules[name]
        import datasets  # noqa: F401  (it notes torchvision's absence before the stand-in exists)

        stub = types.ModuleType("torchvision")
        stub.transforms = types.ModuleType("torchvision.transforms")  # type: ignore[attr-defined]
        stub.io = types.ModuleType("torchvision.io")  # type: ignore[attr-defined]
        sys.modules.update({"torchvision": stub, "torchvision.transforms": stub.transforms,
                            "torchvision.io": stub.io})
    return types.SimpleNamespace(lerobot_dataset=importlib.import_module("ledataset.datasets.lerobot_dataset"),
                                 utils=importlib.import_module("ledataset.datasets.utils"))
