"""A recording as data: the roll-outs, jobs, latents, model versions and learner metrics of one or
more .rrd files as Apache Arrow tables (and Parquet files), read through Rerun's own reader.

    tables = read_recording("run.rrd")                  # or several files of one deployment
    tables.rollouts.num_rows                            # one row per recorded roll-out
    x = tables.trajectories(job="e1-0123456789")        # (N, T, D) float64, numpy
    tables.write_parquet("out/")                        # rollouts.parquet, jobs.parquet, ...

The roll-outs are read at the precision the recorder stores for data (float64: times, values,
reward, task parameters, in each ``/rollouts/<job>`` row; docs/EVENTS.md, "The recording"), not from
the float32 drawings. A file without a footer (its recorder killed with -9) is read by streaming;
a roll-out that several files hold (a restarted recorder's earlier file and its own) appears
once. Schemas: :data:`SCHEMAS` and docs/EVENTS.md, "Recordings as data".
"""
from __future__ import annotations

import json
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from acnmp_core.data.demo_io import DemoArrays
from acnmp_core.datasets.episodes import RolloutEpisode
from services.transport.wire import WireError

from .events import job_names
from .replay import _column, _open
from .segments import recording_segments

__all__ = ["RecordingTables", "SCHEMAS", "read_recording"]

_F64 = pa.list_(pa.float64())
SCHEMAS: dict[str, pa.Schema] = {
    "rollouts": pa.schema([
        ("job", pa.string()), ("attempt", pa.int64()), ("rollout_index", pa.int64()), ("iteration", pa.int64()),
        ("worker", pa.string()), ("host", pa.string()), ("method", pa.string()), ("robot", pa.string()), ("task", pa.string()),
        ("skill", pa.string()), ("model_version", pa.int64()), ("task_params", _F64), ("times", _F64),
        ("trajectory", pa.list_(_F64)), ("steps", pa.int64()), ("dims", pa.int64()), ("reward", _F64),
        ("return", pa.float64()), ("success", pa.bool_()), ("wall_time", pa.float64()), ("event_id", pa.string()),
    ]),
    "jobs": pa.schema([
        ("job", pa.string()), ("attempt", pa.int64()), ("method", pa.string()), ("robot", pa.string()),
        ("task", pa.string()), ("skill", pa.string()), ("seed", pa.int64()), ("config", pa.string()),
        ("task_config", pa.string()), ("output_names", pa.list_(pa.string())),
        ("task_param_names", pa.list_(pa.string())), ("wall_time", pa.float64()),
    ]),
    "latents": pa.schema([
        ("skill", pa.string()), ("label", pa.string()), ("version", pa.int64()), ("latent", _F64),
        ("wall_time", pa.float64()),
    ]),
    "models": pa.schema([
        ("skill", pa.string()), ("version", pa.int64()), ("n_demos", pa.int64()), ("loss", pa.float64()),
        ("note", pa.string()), ("wall_time", pa.float64()),
    ]),
    "metrics": pa.schema([
        ("source", pa.string()), ("phase", pa.string()), ("name", pa.string()), ("step", pa.int64()),
        ("value", pa.float64()), ("wall_time", pa.float64()),
    ]),
}


@dataclass(frozen=True)
class RecordingTables:
    """The tables of :data:`SCHEMAS`, one ``pyarrow.Table`` each, rows in recording order."""

    rollouts: pa.Table
    jobs: pa.Table
    latents: pa.Table
    models: pa.Table
    metrics: pa.Table

    def tables(self) -> dict[str, pa.Table]:
        """``{name: table}`` in :data:`SCHEMAS` order."""
        return {name: getattr(self, name) for name in SCHEMAS}

    def rollout_rows(self, job: str | None = None) -> list[dict]:
        """The roll-out rows (of ``job``, or all) as dicts, with ``times`` (T,), ``trajectory``
        (T, D), ``reward`` (T,) and ``task_params`` (P,) as float64 numpy arrays (None when absent)."""
        rows = self.rollouts.to_pylist()
        out = []
        for r in rows:
            if job is not None and r["job"] != job:
                continue
            r = dict(r)
            for key in ("times", "reward", "task_params"):
                r[key] = None if r[key] is None else np.asarray(r[key], dtype=np.float64)
            r["trajectory"] = None if r["trajectory"] is None else np.asarray(r["trajectory"], dtype=np.float64)
            out.append(r)
        return out

    def trajectories(self, job: str | None = None) -> np.ndarray:
        """The trajectories of ``job`` (or of every job) stacked (N, T, D) float64; ValueError when
        their shapes differ (then use :meth:`rollout_rows`) or a row predates full-precision data."""
        rows = self.rollout_rows(job)
        if any(r["trajectory"] is None for r in rows):
            raise ValueError("some roll-outs were recorded without their data (a recording older than 0.2)")
        shapes = {r["trajectory"].shape for r in rows}
        if len(shapes) > 1:
            raise ValueError(f"trajectories of different shapes {sorted(shapes)}: use rollout_rows()")
        return np.stack([r["trajectory"] for r in rows]) if rows else np.zeros((0, 0, 0))

    def _rows_with_data(self, job: str | None) -> list[dict]:
        """:meth:`rollout_rows` that carry their data; ValueError for a ``job`` with none."""
        rows = [r for r in self.rollout_rows(job) if r["trajectory"] is not None]
        if job is not None and not rows:
            jobs = sorted(set(self.rollouts.column("job").to_pylist()))
            raise ValueError(f"--job {job}: no roll-out of that job in the recording (jobs: {', '.join(jobs) or 'none'})")
        return rows

    def demonstrations(self, *, job: str | None = None, successful: bool = False,
                       best_per_job: bool = False) -> DemoArrays:
        """The recorded roll-outs (of ``job``, or all) as demonstrations in the project's format
        (``acnmp up --demos`` trains on them): times, trajectory and task parameters per roll-out,
        of different lengths padded (``lengths``). ``successful`` keeps the successful roll-outs;
        ``best_per_job`` keeps one per job, its highest return (among the successful ones with
        ``successful``). ValueError when nothing is left, or the roll-outs differ in dimensions or
        task parameters."""
        rows = self._rows_with_data(job)
        if successful:
            rows = [r for r in rows if r["success"]]
        if best_per_job:
            best: dict[str, dict] = {}
            for r in rows:
                if r["job"] not in best or r["return"] > best[r["job"]]["return"]:
                    best[r["job"]] = r
            rows = list(best.values())
        if not rows:
            raise ValueError("no roll-out left to make demonstrations of"
                             + (" (none succeeded)" if successful else ""))
        dims = {r["trajectory"].shape[1] for r in rows}
        params = {0 if r["task_params"] is None else len(r["task_params"]) for r in rows}
        if len(dims) > 1 or len(params) > 1:
            raise ValueError(f"roll-outs of different dimensions {sorted(dims)} or task parameters {sorted(params)}: "
                             "choose one job (--job)")
        n, t, d, p = len(rows), max(len(r["times"]) for r in rows), dims.pop(), params.pop()
        times, values = np.zeros((n, t)), np.zeros((n, t, d))
        task_params, lengths = np.zeros((n, p)), np.zeros(n, dtype=np.int64)
        for i, r in enumerate(rows):
            k = len(r["times"])
            lengths[i] = k
            times[i, :k], values[i, :k] = r["times"], r["trajectory"]
            times[i, k:] = r["times"][-1] + np.arange(1, t - k + 1)  # padding, kept increasing
            if p:
                task_params[i] = r["task_params"]
        return DemoArrays(times, values, task_params, lengths=None if np.all(lengths == t) else lengths)

    def rollout_episodes(self, job: str | None = None) -> list[RolloutEpisode]:
        """The recorded roll-outs (of ``job``, or all) that carry their data, in recording order,
        as :class:`~acnmp_core.datasets.episodes.RolloutEpisode` (what the dataset exporters
        write). ValueError for a ``job`` the recording does not hold."""
        rows = self._rows_with_data(job)
        names = {j["job"]: j for j in self.jobs.select(["job", "output_names", "task_param_names"]).to_pylist()}
        return [RolloutEpisode(r["times"], r["trajectory"],
                               np.zeros(len(r["times"])) if r["reward"] is None else r["reward"],
                               bool(r["success"]), float(r["return"] or 0.0),
                               np.zeros(0) if r["task_params"] is None else r["task_params"],
                               job=r["job"] or "", method=r["method"] or "", skill=r["skill"] or "",
                               robot=r["robot"] or "", task=r["task"] or "", rollout_index=int(r["rollout_index"] or 0),
                               value_names=tuple(names.get(r["job"], {}).get("output_names") or ()),
                               task_param_names=tuple(names.get(r["job"], {}).get("task_param_names") or ()),
                               wall_time=r["wall_time"])
                for r in rows]

    def write_parquet(self, out_dir: str | os.PathLike) -> dict[str, Path]:
        """Write ``<out_dir>/<table>.parquet`` for every table (the directory is created);
        returns the paths by table name."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = {}
        for name, table in self.tables().items():
            paths[name] = out / f"{name}.parquet"
            pq.write_table(table, paths[name])
        return paths


def _seconds(batch: pa.RecordBatch, timeline: str = "wall_time") -> list[float | None]:
    if timeline not in batch.schema.names:
        return [None] * batch.num_rows
    return [None if v is None else v / 1e9 for v in batch.column(timeline).cast(pa.int64()).to_pylist()]


def _lists(batch: pa.RecordBatch, name: str) -> list[list | None]:
    """A component column whose cells are whole arrays (not 1-element lists): the list per row."""
    if name not in batch.schema.names:
        return [None] * batch.num_rows
    return batch.column(name).to_pylist()


def read_recording(paths: str | os.PathLike | Iterable[str | os.PathLike]) -> RecordingTables:
    """Read one .rrd (or several files of one deployment, oldest first) into :class:`RecordingTables`;
    each file with its segments (``<stem>.<n><suffix>``, services/recording/segments.py).

    Raises FileNotFoundError for a missing file, ValueError for one that is not a readable
    recording. Roll-outs held by several files (same job, attempt and index) are kept once.
    """
    given = [Path(paths)] if isinstance(paths, (str, os.PathLike)) else [Path(p) for p in paths]
    files = []
    for path in given:
        for f in recording_segments(path) or [path]:
            if f not in files:
                files.append(f)
    rows: dict[str, list[dict]] = {name: [] for name in SCHEMAS}
    seen: set[tuple] = set()
    for path in files:
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no such recording")
        reader, stores = _open(path)
        for store in stores:
            for chunk in reader.stream(store=store):
                if chunk.is_static or chunk.is_empty:
                    continue
                parts = chunk.entity_path.strip("/").split("/")
                reader_fn = _READERS.get(parts[0])
                if reader_fn is not None and len(parts) >= 2:
                    reader_fn(parts, chunk.to_record_batch(), rows, seen)
    jobs = {}
    for j in rows["jobs"]:  # the last attempt's description of each job
        jobs[j["job"]] = j
    for r in rows["rollouts"]:
        about = jobs.get(r["job"], {})
        for key in ("method", "robot", "task"):
            r[key] = about.get(key)
        r["skill"] = r["skill"] or about.get("skill")
    tables = {name: pa.Table.from_pylist(rows[name], schema=SCHEMAS[name]) for name in SCHEMAS}
    # the task's parameters as columns of their own, which a reader can filter on
    job_params = [_flat("task_config", json.loads(j["task_config"]) if j.get("task_config") else {})
                  for j in rows["jobs"]]
    by_job = {j["job"]: params for j, params in zip(rows["jobs"], job_params)}  # the last attempt's
    tables["jobs"] = _with_columns(tables["jobs"], job_params)
    tables["rollouts"] = _with_columns(tables["rollouts"], [
        {**by_job.get(r["job"], {}), **_flat("task_params", r["task_params"] or [])} for r in rows["rollouts"]])
    return RecordingTables(**tables)


def _flat(prefix: str, value) -> dict[str, object]:
    """``value`` (a JSON value) as ``{column: scalar}``: a map's entries as ``<prefix>.<key>``, a
    list's elements as ``<prefix>.<index>``, recursively (a via-point ``point`` [[t, x, y], ...]
    gives ``task_config.point.1.2``)."""
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in _flat(f"{prefix}.{key}", item).items()}
    if isinstance(value, (list, tuple)):
        return {k: v for i, item in enumerate(value) for k, v in _flat(f"{prefix}.{i}", item).items()}
    return {prefix: value}


def _with_columns(table: pa.Table, extra: list[dict[str, object]]) -> pa.Table:
    """``table`` with a column per name in ``extra`` (one map per row; null where a row lacks the
    name), sorted by name after the table's own; a column whose rows mix types holds them as text."""
    for name in sorted({k for row in extra for k in row}):
        values = [row.get(name) for row in extra]
        try:
            column = pa.array(values)
        except (pa.ArrowInvalid, pa.ArrowTypeError):
            column = pa.array([None if v is None else json.dumps(v) for v in values], type=pa.string())
        if pa.types.is_null(column.type):
            column = column.cast(pa.float64())
        table = table.append_column(name, column)
    return table


def _rollouts(parts, batch, rows, seen) -> None:
    cols = {c: _column(batch, c) for c in ("rollout_index", "worker", "host", "success", "ret", "steps", "iteration", "dims",
                                            "skill", "attempt", "model_version", "event_id")}
    arrays = {c: _lists(batch, c) for c in ("times", "values", "reward", "task_params")}
    wall = _seconds(batch)
    for i in range(batch.num_rows):
        attempt = cols["attempt"][i]
        key = (parts[1], -1 if attempt is None else int(attempt), cols["rollout_index"][i])
        if key in seen:
            continue
        seen.add(key)
        dims, values = cols["dims"][i], arrays["values"][i]
        trajectory = None if values is None or not dims else np.asarray(values).reshape(-1, int(dims)).tolist()
        iteration = cols["iteration"][i]
        rows["rollouts"].append({
            "job": parts[1], "attempt": key[1], "rollout_index": key[2],
            "iteration": None if iteration in (None, -1) else iteration, "worker": cols["worker"][i],
            "host": cols["host"][i] or None,
            "skill": cols["skill"][i], "model_version": cols["model_version"][i],
            "task_params": arrays["task_params"][i], "times": arrays["times"][i], "trajectory": trajectory,
            "steps": cols["steps"][i], "dims": dims, "reward": arrays["reward"][i], "return": cols["ret"][i],
            "success": cols["success"][i], "wall_time": wall[i], "event_id": cols["event_id"][i]})


def _jobs(parts, batch, rows, seen) -> None:
    cols = {c: _column(batch, c) for c in ("method", "robot", "task", "skill", "seed", "attempt", "config",
                                            "task_config", "output_names", "task_param_names")}
    wall = _seconds(batch)
    for i in range(batch.num_rows):
        row = {c: cols[c][i] for c in cols}
        for key in ("seed", "attempt"):
            row[key] = None if row[key] in (None, -1) else row[key]
        for key in ("output_names", "task_param_names"):  # JSON text in the recording
            try:
                row[key] = job_names(row, key)
            except WireError:  # a hand-made recording's: unnamed, as an older one's
                row[key] = None
        rows["jobs"].append({"job": parts[1], **row, "wall_time": wall[i]})


def _latents(parts, batch, rows, seen) -> None:
    values = _lists(batch, "BarChart:values")
    versions = _column(batch, "model_version")
    wall = _seconds(batch)
    for i in range(batch.num_rows):
        latent = values[i]
        if isinstance(latent, list) and latent and isinstance(latent[0], dict):
            latent = latent[0].get("buffer")  # one tensor-data struct per row: its buffer (float32)
        rows["latents"].append({"skill": parts[1], "label": parts[2] if len(parts) > 2 else "",
                                "version": versions[i], "latent": None if latent is None else
                                [float(x) for x in np.asarray(latent, dtype=np.float64).reshape(-1)],
                                "wall_time": wall[i]})


def _models(parts, batch, rows, seen) -> None:
    cols = {c: _column(batch, c) for c in ("version", "x_n_demos", "x_loss", "x_note")}
    wall = _seconds(batch)
    for i in range(batch.num_rows):
        rows["models"].append({"skill": parts[1], "version": cols["version"][i], "n_demos": cols["x_n_demos"][i],
                               "loss": cols["x_loss"][i], "note": cols["x_note"][i], "wall_time": wall[i]})


def _metrics(parts, batch, rows, seen) -> None:
    if len(parts) != 4:
        return
    steps, values, wall = _column(batch, "metric_step"), _column(batch, "Scalars:scalars"), _seconds(batch)
    for i in range(batch.num_rows):
        rows["metrics"].append({"source": parts[1], "phase": parts[2], "name": parts[3], "step": steps[i],
                                "value": values[i], "wall_time": wall[i]})


_READERS = {"rollouts": _rollouts, "jobs": _jobs, "latent": _latents, "models": _models, "metrics": _metrics}


def job_config(row: dict) -> dict:
    """The ``config`` JSON of a jobs-table row as a dict ({} when absent)."""
    return json.loads(row["config"]) if row.get("config") else {}
