"""ROS 2 bags (rosbag2, MCAP or SQLite storage) in and out, with ``rosbags`` (pure Python, no ROS).

In: :func:`read_rosbag2` reads the messages a :class:`BagSelection` names from one or more bags
into :class:`~.episodes.DatasetEpisodes` that :func:`~.selection.select_demos` turns into
demonstrations: one episode per bag, or several per bag split by a topic's messages, a gap in
time or given time ranges (:class:`Split`); each row of the trajectory from the numbers a
reference selects in one message (``/joint_states:position[shoulder,elbow]``,
``/arm/cmd:points[*].positions``: :mod:`.message_paths`); each message's time its header stamp
(else its receive time); task parameters from a topic's first or last message in the episode
(``/goal:pose.position@first``), from the bag's metadata (``custom_data``, e.g. the exports'
``acnmp.task_params``) or given per episode. :func:`describe_bags` lists topics, types and counts.

Out: :func:`write_rosbag2` writes each roll-out as a bag of its own (``DIR/rollout_0000/``...):
its commanded trajectory as one ``trajectory_msgs/msg/JointTrajectory`` on ``/acnmp/trajectory``
(joint names the skill's output names, ``time_from_start`` the recorded time in seconds, or scaled
to a given duration), its
reward per step on ``/acnmp/reward`` (``std_msgs/msg/Float64``), its success on ``/acnmp/success``
(``std_msgs/msg/Bool``), its task parameters on ``/acnmp/task_params``
(``std_msgs/msg/Float64MultiArray``, the names as the dimension's label), and the job, skill,
method, robot, task, index, success, return, task parameters and names in the bag's
``metadata.yaml`` (``custom_data``, keys ``acnmp.*``), where ``ros2 bag info`` users look.
"""
from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .episodes import (DatasetEpisodes, DatasetError, Episode, RolloutEpisode, check_rollouts, new_directory,
                       rollout_names)
from .message_paths import NAME_FIELDS, MessageRef, PathError, extract, msgtype, path_of

#: storage plugins a bag is written with (``mcap`` the default, ``sqlite3`` the older one)
STORAGES = ("mcap", "sqlite3")
#: where a message's time comes from: its header's stamp, or when the bag received it
TIME_SOURCES = ("header", "receive")
#: the topics and metadata keys the export writes (and the round trip reads back)
TRAJECTORY_TOPIC, REWARD_TOPIC, SUCCESS_TOPIC, PARAMS_TOPIC = (
    "/acnmp/trajectory", "/acnmp/reward", "/acnmp/success", "/acnmp/task_params")
META_PREFIX = "acnmp."
#: the per-frame feature holding each row's time (s) in the episodes read
TIME = "time"


def _rosbags():
    """rosbags' modules (rosbag2, typesys); DatasetError when it is not installed."""
    try:
        import rosbags.rosbag2 as rosbag2
        import rosbags.typesys as typesys
    except ImportError:
        raise DatasetError("rosbags", "not installed (expected it for ROS 2 bags: pip install 'acnmp[rosbag]'; "
                                      "bash scripts/setup.sh installs it)") from None
    return rosbag2, typesys


def typestore():
    """The message types bags are read and written with: ROS 2 Jazzy's (every standard message);
    a bag's own definitions are added as it is read."""
    _, typesys = _rosbags()
    return typesys.get_typestore(typesys.Stores.ROS2_JAZZY)


@dataclass(frozen=True)
class Split:
    """How a bag becomes episodes: ``kind`` "bag" (one episode per bag), "topic" (each message on
    ``topic`` starts one), "gap" (a gap of more than ``gap`` s between trajectory rows ends one)
    or "ranges" (``ranges``: (start, stop) s from the trajectory topic's first message)."""

    kind: str = "bag"
    topic: str | None = None
    gap: float | None = None
    ranges: tuple[tuple[float, float], ...] = ()

    @property
    def text(self) -> str:
        if self.kind == "topic":
            return f"topic:{self.topic}"
        if self.kind == "gap":
            return f"gap:{self.gap:g}"
        return "ranges:" + ",".join(f"{a:g}-{b:g}" for a, b in self.ranges) if self.kind == "ranges" else "bag"


def parse_split(text: str) -> Split:
    """A :class:`Split` from ``topic:/TOPIC``, ``gap:SECONDS`` or ``ranges:A-B[,C-D...]`` (seconds);
    ValueError naming the text when it is malformed."""
    kind, _, rest = text.strip().partition(":")
    try:
        if kind == "topic" and rest.startswith("/"):
            return Split("topic", topic=rest)
        if kind == "gap":
            gap = float(rest)
            if gap > 0 and math.isfinite(gap):
                return Split("gap", gap=gap)
        if kind == "ranges" and rest:
            ranges = []
            for part in rest.split(","):
                a, sep, b = part.strip().partition("-")
                if not sep:
                    raise ValueError(part)
                lo, hi = float(a), float(b)
                if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
                    raise ValueError(part)
                ranges.append((lo, hi))
            return Split("ranges", ranges=tuple(ranges))
    except ValueError:
        pass
    raise ValueError(f"{text!r}: not a split (expected topic:/TOPIC, gap:SECONDS or ranges:A-B[,C-D...] "
                     "in seconds from the trajectory's first message)")


@dataclass(frozen=True)
class BagSelection:
    """What to read of the bags.

    trajectory : references on one topic whose numbers, concatenated, make each row.
    task_params : references with ``at`` "first"/"last" (a topic's message in the episode).
    meta_params : keys of the bags' metadata (``custom_data``) that hold numbers.
    split : how bags become episodes. time : "header", "receive" or None (the header's stamp
    where the type has a header and it is set, else the receive time). given : task parameters
    given per episode (one row each, in episode order), named ``given_names``.
    """

    trajectory: tuple[MessageRef, ...]
    task_params: tuple[MessageRef, ...] = ()
    meta_params: tuple[str, ...] = ()
    split: Split = field(default_factory=Split)
    time: str | None = None
    given: tuple[tuple[float, ...], ...] = ()
    given_names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.trajectory:
            raise ValueError("trajectory: expected at least one reference")
        topics = sorted({r.topic for r in self.trajectory})
        if len(topics) > 1:
            raise ValueError(f"trajectory: references on one topic (got {', '.join(topics)}): its messages make the rows")
        if any(r.at is None for r in self.task_params):
            bad = next(r for r in self.task_params if r.at is None)
            raise ValueError(f"task params: {bad.text!r}: a topic's message at the episode's first or last message "
                             f"(expected {bad.text}@first or {bad.text}@last)")
        if self.time is not None and self.time not in TIME_SOURCES:
            raise ValueError(f"time: expected one of {TIME_SOURCES} for a bag, got {self.time!r}")
        if len({len(g) for g in self.given}) > 1:
            raise ValueError("given task params: expected the same number per episode")
        if self.given and self.given_names and len(self.given_names) != len(self.given[0]):
            raise ValueError(f"given task param names: expected {len(self.given[0])}, got {len(self.given_names)}")

    @property
    def feature(self) -> str:
        """The name the trajectory has in the episodes read (its references' text)."""
        return ",".join(r.text for r in self.trajectory)


def bag_dir(path: str | os.PathLike) -> Path:
    """The bag directory of ``path`` (the directory with ``metadata.yaml``, or a storage file in
    it); DatasetError when it is not a rosbag2 bag."""
    p = Path(path)
    for candidate in (p, p.parent) if p.is_file() else (p,):
        if (candidate / "metadata.yaml").is_file():
            return candidate
    if p.is_dir() and any(p.glob("*/metadata.yaml")):
        raise DatasetError(p, "is a directory of bags (expected the bags themselves: e.g. DIR/*)")
    raise DatasetError(p, "not a ROS 2 bag (expected a directory with metadata.yaml, as `ros2 bag record` writes it)")


class _Bag:
    """One open bag: its topics and types, its metadata, and its messages deserialised.

    Messages are read with ``store`` (ROS 2 Jazzy's types, shared by the bags of one import, so a
    type's generated code serves them all) plus the definitions a bag holds of types Jazzy lacks;
    a bag whose definition of a standard type differs from Jazzy's (its RIHS01 digest) is read
    with its own definitions alone (:meth:`_own_store`), as ``rosbags.highlevel.AnyReader`` does."""

    def __init__(self, path: Path, store) -> None:
        rosbag2, typesys = _rosbags()
        self.path = path
        self.reader = rosbag2.Reader(path)
        try:
            self.reader.open()
        except Exception as exc:  # noqa: BLE001 - rosbags' own errors for a damaged bag, one line each
            raise DatasetError(path, f"not a readable bag ({_line(exc)})") from None
        conns = self.reader.connections
        self.types = {c.topic: c.msgtype for c in conns}
        self.store = store
        try:
            if any(c.digest and c.msgtype in store.fielddefs and _digest(store, c.msgtype) != c.digest
                   for c in conns if c.digest.startswith("RIHS01_")):
                self.store = _own_store(conns, store, typesys)
            else:
                for c in conns:
                    if c.msgtype not in self.store.fielddefs and c.msgdef.data:
                        self.store.register(_definitions(c, typesys))
        except Exception as exc:  # noqa: BLE001 - a definition rosbags cannot parse
            self.close()
            raise DatasetError(path, f"message definitions not readable ({_line(exc)})") from None

    def close(self) -> None:
        self.reader.close()

    def custom_data(self) -> dict[str, str]:
        """The bag's ``custom_data`` (empty when it has none), as rosbags read it from metadata.yaml."""
        custom = getattr(getattr(self.reader.storage, "metadata", None), "custom", None)
        return {str(k): str(v) for k, v in (custom or {}).items()}

    def check_topic(self, topic: str, what: str) -> str:
        """The type of ``topic``; DatasetError listing the bag's topics when it has none such."""
        if topic not in self.types:
            raise DatasetError(self.path, f"no topic {topic!r} ({what}; expected one of "
                                          f"{', '.join(sorted(self.types)) or 'none'})")
        return self.types[topic]

    def messages(self, topics: set[str], clock: str | None):
        """``(topic, time in s from the bag's start, message)`` of ``topics``, in the bag's order."""
        conns = [c for c in self.reader.connections if c.topic in topics]
        for conn in conns:
            if conn.msgtype not in self.store.fielddefs:
                raise DatasetError(self.path, f"topic {conn.topic!r}: message type {conn.msgtype} is unknown (expected "
                                              "a ROS 2 Jazzy type or one whose definition the bag holds, as bags "
                                              "recorded since ROS 2 Iron do)")
        start = self.reader.start_time
        counts = dict.fromkeys((c.id for c in conns), 0)
        stored = self.reader.messages(connections=conns)
        while True:
            try:
                conn, stamp, raw = next(stored)
            except StopIteration:
                break
            except Exception as exc:  # noqa: BLE001 - the storage's own errors for damaged bytes (rosbags'
                # ReaderError, apsw's CorruptError, an OverflowError of a length read from random bytes)
                raise DatasetError(self.path, f"damaged or truncated: its storage cannot be read past "
                                              f"{sum(counts.values())} messages ({_line(exc)})") from None
            counts[conn.id] += 1
            try:
                msg = self.store.deserialize_cdr(raw, conn.msgtype)
            except Exception as exc:  # noqa: BLE001 - a damaged message
                raise DatasetError(self.path, f"topic {conn.topic!r}: cannot read its {conn.msgtype} messages "
                                              f"({_line(exc)})") from None
            yield conn.topic, (_stamp(msg, clock, stamp, self.path, conn.topic) - start) * 1e-9, msg
        for conn in conns:  # a message lost to damage (a record whose channel or time was overwritten)
            if conn.msgcount and counts[conn.id] != conn.msgcount:
                raise DatasetError(self.path, f"damaged or truncated: {counts[conn.id]} messages on {conn.topic!r} "
                                              f"where its metadata.yaml counts {conn.msgcount}")


def _definitions(conn, typesys) -> dict:
    """The types a connection's message definition (MSG or IDL text) holds."""
    data = conn.msgdef.data
    if getattr(conn.msgdef.format, "name", "") == "IDL":
        sep = "=" * 80 + "\n"
        out: dict = {}
        for part in (data.split(sep)[1:] if data.startswith(f"{sep}IDL: ") else [data]):
            out.update(typesys.get_types_from_idl(part.split("\n", 1)[1] if part.startswith("IDL: ") else part))
        return out
    return typesys.get_types_from_msg(data, conn.msgtype)


def _own_store(conns, store, typesys):
    """A typestore of the bag's own definitions, with Jazzy's for the types it does not define."""
    own = typesys.get_typestore(typesys.Stores.EMPTY)
    types: dict = {}
    for c in conns:
        if c.msgdef.data:
            types.update(_definitions(c, typesys))
    types.update({k: v for k, v in _closure(store, {c.msgtype for c in conns} - set(types)).items() if k not in types})
    own.register(types)
    return own


_DIGESTS: dict[tuple[int, str], str] = {}


def _digest(store, name: str) -> str:
    """The RIHS01 digest of type ``name`` in ``store`` (computed once per store and type)."""
    key = (id(store), name)
    if key not in _DIGESTS:
        _DIGESTS[key] = store.hash_rihs01(name)
    return _DIGESTS[key]


def _closure(store, names: set[str]) -> dict:
    """The definitions (``store.fielddefs``) of the types ``names`` and of every type in them."""
    out, todo = {}, list(names)
    while todo:
        name = todo.pop()
        if name in out or name not in store.fielddefs:
            continue
        out[name] = store.fielddefs[name]
        for _, (node, spec) in out[name][1]:
            inner = spec if getattr(node, "name", "") == "NAME" else spec[0] if isinstance(spec, tuple) else None
            if isinstance(inner, str):
                todo.append(inner)
            elif isinstance(inner, tuple) and getattr(inner[0], "name", "") == "NAME":
                todo.append(inner[1])
    return out


def _line(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text.splitlines()[0]


def _stamp(msg, clock: str | None, received: int, path: Path, topic: str) -> int:
    """A message's time (ns): its header's stamp or ``received`` (see :class:`BagSelection`)."""
    header = getattr(msg, "header", None)
    if clock == "receive":
        return received
    if header is None:
        if clock == "header":
            raise DatasetError(path, f"topic {topic!r}: {msgtype(msg)} has no header (expected --time receive)")
        return received
    ns = int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)
    return ns if ns or clock == "header" else received


def _meta_value(text: str) -> np.ndarray | None:
    """A custom_data value as numbers (a JSON number, boolean or list of them), else None."""
    try:
        value = json.loads(text)
    except ValueError:
        return None
    if isinstance(value, (bool, int, float)):
        return np.array([float(value)])
    if isinstance(value, list) and all(isinstance(v, (bool, int, float)) for v in value):
        return np.asarray(value, dtype=np.float64)
    return None


@dataclass
class _Rows:
    """A topic's rows as read: times (R,) s, values (R, k), the components' names."""

    times: list[float] = field(default_factory=list)
    values: list[np.ndarray] = field(default_factory=list)
    names: list[str] | None = None


def _by_name(bag: _Bag, ref: MessageRef, t: float, rows: np.ndarray, names: list[str],
             columns: dict[str, tuple[str, ...]]) -> np.ndarray:
    """``rows`` (R, k) of one message, its columns named ``names`` by the message, put in the order
    the first message of the import named them (``columns[ref.text]``, set by that message):
    JointState and JointTrajectory may list their joints in another order in every message, so
    a column is a joint by its name, never by its place. DatasetError when the message names
    other components than the first did (a joint more or less: select them by name)."""
    first = columns.setdefault(ref.text, tuple(names))
    if tuple(names) == first:
        return rows
    if len(set(names)) == len(names) and sorted(names) == sorted(first):
        return rows[:, [names.index(n) for n in first]]
    raise DatasetError(bag.path, f"topic {ref.topic!r}: the message at {t:.6f} s names {', '.join(names) or 'none'} "
                                 f"where the first named {', '.join(first) or 'none'} (expected the same components in "
                                 f"every message: select them by name, e.g. [{','.join(first[:2])}])", ref.text)


def _trajectory(bag: _Bag, sel: BagSelection, msgs, columns: dict[str, tuple[str, ...]]) -> _Rows:
    out = _Rows()
    for t, msg in msgs:
        parts = []
        for ref in sel.trajectory:
            try:
                rows, offsets, names = extract(msg, path_of(ref, msgtype(msg)))
            except PathError as exc:
                raise DatasetError(bag.path, f"topic {ref.topic!r}: {exc}", ref.text) from None
            parts.append((_by_name(bag, ref, t, rows, names, columns), offsets, list(columns[ref.text])))
        counts = {p[0].shape[0] for p in parts}
        if len(counts) > 1:
            raise DatasetError(bag.path, f"the references give {sorted(counts)} rows per message (expected as many "
                                         "each)", sel.feature)
        values = np.concatenate([p[0] for p in parts], axis=1)
        bad = ~np.isfinite(values)
        if bad.any():
            raise DatasetError(bag.path, f"topic {sel.trajectory[0].topic!r}: the message at {t:.6f} s holds NaN or "
                                         "inf (expected finite numbers)", sel.feature)
        out.times.extend((t + parts[0][1]).tolist())
        out.values.extend(values)
        out.names = out.names or [n for p in parts for n in p[2]]
    return out


def _windows(bag: _Bag, sel: BagSelection, times: np.ndarray, split_times: list[float]) -> list[tuple[float, float]]:
    """The episodes' time windows [start, stop) in s (rows and task-parameter messages in them
    belong to the episode)."""
    split = sel.split
    if split.kind == "bag":
        return [(-math.inf, math.inf)]
    if split.kind == "topic":
        if not split_times:
            raise DatasetError(bag.path, f"no message on {split.topic!r} to split by (expected one per episode)")
        return list(zip(split_times, [*split_times[1:], math.inf]))
    if split.kind == "ranges":
        first = times[0]
        return [(first + a, first + b + 1e-9) for a, b in split.ranges]
    ends = np.flatnonzero(np.diff(times) > split.gap)  # gap: each episode to its last row
    stops = [float(times[i]) for i in ends] + [float(times[-1])]
    return [(lo, hi + 1e-9) for lo, hi in zip([-math.inf, *[s + 1e-9 for s in stops[:-1]]], stops)]


def read_rosbag2(bags: Sequence[str | os.PathLike], sel: BagSelection) -> DatasetEpisodes:
    """The episodes ``sel`` makes of ``bags``: per episode the trajectory (T, D) as a per-frame
    feature named :attr:`BagSelection.feature`, each row's time (s, from the bag's start) as
    :data:`TIME`, the task parameters as per-episode fields named by their references' text
    (the given ones as ``given``), the bags' ``custom_data`` as fields and labels, and success
    from ``acnmp.success`` where the metadata has it. DatasetError (one line naming the bag, the
    reference and what was expected) for a path that is not a bag, an unknown topic or field, a
    message type neither ROS 2 Jazzy nor the bag defines, an episode without messages, a NaN."""
    if not bags:
        raise DatasetError("rosbag2", "no bag given (expected one or more bag directories)")
    store, episodes, names, columns = typestore(), [], {}, {}
    paths = [bag_dir(b) for b in bags]
    for path in paths:
        bag = _Bag(path, store)
        try:
            episodes += _read_bag(bag, sel, names, columns, first_index=len(episodes))
        finally:
            bag.close()
    if sel.given:
        if len(sel.given) != len(episodes):
            raise DatasetError(paths[0] if len(paths) == 1 else "rosbag2",
                               f"{len(sel.given)} rows of given task parameters for {len(episodes)} episodes "
                               "(expected one per episode, in order)")
        for ep, row in zip(episodes, sel.given):
            ep.fields["given"] = np.asarray(row, dtype=np.float64)
        names["given"] = tuple(sel.given_names) or tuple(f"p{i}" for i in range(len(sel.given[0])))
    where = str(paths[0]) if len(paths) == 1 else os.path.commonpath([str(p) for p in paths])
    data = DatasetEpisodes(where, "rosbag2", episodes, TIME, names, catalog=str(paths[0] / "metadata.yaml"))
    data.files.update({name: where for name in (sel.feature, TIME, *(r.text for r in sel.task_params))})
    return data


def _read_bag(bag: _Bag, sel: BagSelection, names: dict, columns: dict, first_index: int) -> list[Episode]:
    topic = sel.trajectory[0].topic
    bag.check_topic(topic, "the trajectory's")
    for ref in sel.task_params:
        bag.check_topic(ref.topic, f"task parameter {ref.text}")
    if sel.split.kind == "topic":
        bag.check_topic(sel.split.topic, "the split's")
    wanted = {topic, *(r.topic for r in sel.task_params), *([sel.split.topic] if sel.split.kind == "topic" else [])}
    by_topic: dict[str, list] = {t: [] for t in wanted}
    for name, t, msg in bag.messages(wanted, sel.time):
        by_topic[name].append((t, msg))
    if not by_topic[topic]:
        raise DatasetError(bag.path, f"no message on {topic!r} (expected the trajectory's messages)", sel.feature)
    rows = _trajectory(bag, sel, by_topic[topic], columns)
    times, values = np.asarray(rows.times), np.asarray(rows.values)
    order = np.argsort(times, kind="stable")  # messages are in receive order; stamps may differ
    times, values = times[order], values[order]
    names.setdefault(sel.feature, tuple(rows.names or ()))
    custom = bag.custom_data()
    fields = {k: v for k, v in ((k, _meta_value(t)) for k, t in custom.items()) if v is not None}
    labels = {k: t for k, t in custom.items() if k not in fields}
    for key in sel.meta_params:
        if key not in fields:
            raise DatasetError(bag.path / "metadata.yaml", f"no numeric custom_data {key!r} (expected one of "
                                                           f"{', '.join(sorted(fields)) or 'none'})", key)
    success = fields.get(f"{META_PREFIX}success")
    split_times = [t for t, _ in by_topic.get(sel.split.topic, [])] if sel.split.kind == "topic" else []
    episodes = []
    for k, (lo, hi) in enumerate(_windows(bag, sel, times, split_times)):
        inside = (times >= lo) & (times < hi)
        if not inside.any():
            raise DatasetError(bag.path, f"episode {first_index + k} ({sel.split.text}, {lo:.3f} to {hi:.3f} s): no "
                                         f"message on {topic!r} (expected its trajectory)", sel.feature)
        params = {}
        for ref in sel.task_params:
            params[ref.text] = _param(bag, ref, by_topic[ref.topic], lo, hi, first_index + k, names, columns)
        episodes.append(Episode(first_index + k, {sel.feature: values[inside], TIME: times[inside].reshape(-1, 1)},
                                {**fields, **params}, dict(labels),
                                None if success is None else bool(success[0])))
    for key in sel.meta_params:  # names the export wrote beside its task parameters
        given = custom.get(f"{META_PREFIX}task_param_names") if key == f"{META_PREFIX}task_params" else None
        if given:
            try:
                names.setdefault(key, tuple(str(n) for n in json.loads(given)))
            except ValueError:
                pass
    return episodes


def _param(bag: _Bag, ref: MessageRef, msgs: list, lo: float, hi: float, index: int, names: dict,
           columns: dict) -> np.ndarray:
    inside = [(t, m) for t, m in msgs if lo <= t < hi]
    if not inside:
        raise DatasetError(bag.path, f"episode {index}: no message on {ref.topic!r} between {lo:.3f} and {hi:.3f} s "
                                     "(expected one to take the task parameters from)", ref.text)
    t, msg = inside[0] if ref.at == "first" else inside[-1]
    try:
        rows, _, labels = extract(msg, path_of(ref, msgtype(msg)))
    except PathError as exc:
        raise DatasetError(bag.path, f"topic {ref.topic!r}: {exc}", ref.text) from None
    if rows.shape[0] != 1:
        raise DatasetError(bag.path, f"gives {rows.shape[0]} rows per message (expected one: not [*])", ref.text)
    if not np.isfinite(rows).all():
        raise DatasetError(bag.path, f"the message at {t:.6f} s holds NaN or inf (expected finite numbers)", ref.text)
    row = _by_name(bag, ref, t, rows, _array_labels(msg, labels), columns)[0]
    names.setdefault(ref.text, columns[ref.text])
    return row


def _array_labels(msg, labels: list[str]) -> list[str]:
    """A MultiArray's component names from its first dimension's label, when it lists one per
    component (comma-separated, as :func:`write_rosbag2` writes them)."""
    layout = getattr(msg, "layout", None)
    dims = getattr(layout, "dim", None)
    if dims:
        given = [n.strip() for n in str(dims[0].label).split(",")]
        if len(given) == len(labels) and all(given):
            return given
    return labels


def describe_bags(bags: Sequence[str | os.PathLike]) -> str:
    """What each bag holds, one line per topic: its type, message count and fields (numbers,
    arrays of numbers ``[]``, messages with their numeric fields: ``point (Point: x, y, z)``, the
    paths ``/goal:point[0:2]`` selects from); under a topic whose messages name their components
    (JointState's ``name``, JointTrajectory's ``joint_names``) the names its messages give, in the
    first message's order, and in how many orders they come (the import places them by name); and
    the bag's custom_data keys. DatasetError for a path that is not a bag or a damaged one."""
    store, lines = typestore(), []
    for b in bags:
        bag = _Bag(bag_dir(b), store)
        try:
            r = bag.reader
            seconds = (r.end_time - r.start_time) * 1e-9 if r.message_count else 0.0
            lines.append(f"{bag.path}: ROS 2 bag, {len(bag.types)} topics, {r.message_count} messages over "
                         f"{seconds:.3f} s")
            named = _names_seen(bag)
            for topic, info in sorted(r.topics.items()):
                fields = _field_kinds(bag.store, info.msgtype)
                lines.append(f"  {topic:<28} {info.msgtype:<38} {info.msgcount:>7} messages  {fields}")
                for key, orders in named.get(topic, {}).items():
                    first = orders[0]
                    again = f" (in {len(orders)} orders: placed by name)" if len(orders) > 1 else ""
                    lines.append(f"  {'':<28} {key} seen: {', '.join(first) or 'none'}{again}")
            custom = bag.custom_data()
            if custom:
                lines.append("  custom_data: " + ", ".join(sorted(custom)))
        finally:
            bag.close()
    return "\n".join(lines)


def _names_seen(bag: _Bag) -> dict[str, dict[str, list[tuple[str, ...]]]]:
    """{topic: {name field: the distinct name lists its messages give, first seen first}} for the
    topics whose type has a name field (:data:`~.message_paths.NAME_FIELDS`) and whose type is known."""
    topics = {t for t, kind in bag.types.items() if kind in bag.store.fielddefs
              and any(name in NAME_FIELDS for name, _ in bag.store.fielddefs[kind][1])}
    seen: dict[str, dict[str, list[tuple[str, ...]]]] = {}
    for topic, _, msg in bag.messages(topics, "receive") if topics else ():
        for key in NAME_FIELDS:
            names = getattr(msg, key, None)
            if isinstance(names, list):
                orders = seen.setdefault(topic, {}).setdefault(key, [])
                if tuple(names) not in orders:
                    orders.append(tuple(names))
    return seen


def _field_kinds(store, type_name: str) -> str:
    """``name (kind), ...`` of a type's fields, from the typestore's definitions; a message field
    with the numeric fields inside it (``point (Point: x, y, z)``)."""
    try:
        _, fields = store.fielddefs[type_name]
    except KeyError:
        return "(fields unknown)"
    out = []
    for name, (node, spec) in fields:
        kind = getattr(node, "name", str(node))
        if kind == "BASE":
            out.append(name if spec[0] != "string" else f"{name} (text)")
        elif kind == "NAME":
            inside = ", ".join(_numeric_leaves(store, spec)) if name != "header" else ""
            out.append(f"{name} ({spec.split('/')[-1]}{': ' + inside if inside else ''})")
        elif getattr(spec[0][0], "name", "") == "BASE":
            out.append(f"{name}[] ({spec[0][1][0]})" if spec[0][1][0] != "string" else f"{name}[] (text)")
        else:  # a sequence of messages: [*] takes a row from each
            inside = ", ".join(_numeric_leaves(store, spec[0][1]))
            out.append(f"{name}[] ({spec[0][1].split('/')[-1]}{': ' + inside if inside else ''})")
    return ", ".join(out)


def _numeric_leaves(store, type_name: str, prefix: str = "", depth: int = 0) -> list[str]:
    """The paths of the numbers inside a message type, as a reference names them (``x``,
    ``position.x``, ``positions[]``); headers and text left out, as :func:`~.message_paths.extract`
    leaves them out of a message it flattens."""
    if depth > 4 or type_name not in store.fielddefs:
        return []
    out = []
    for name, (node, spec) in store.fielddefs[type_name][1]:
        kind = getattr(node, "name", str(node))
        if name == "header":
            continue
        if kind == "BASE" and spec[0] != "string":
            out.append(f"{prefix}{name}")
        elif kind == "NAME":
            out += _numeric_leaves(store, spec, f"{prefix}{name}.", depth + 1)
        elif kind != "BASE" and getattr(spec[0][0], "name", "") == "BASE" and spec[0][1][0] != "string":
            out.append(f"{prefix}{name}[]")
    return out


def write_rosbag2(root: str | os.PathLike, rollouts: list[RolloutEpisode], *, storage: str = "mcap",
                  duration: float | None = None) -> Path:
    """Write ``rollouts`` as bags in the new directory ``root`` (which must not exist, or be
    empty), one bag per roll-out, ``rollout_0000``, ``rollout_0001``, ... in recording order,
    as the module docstring describes, with ``storage`` ("mcap" or "sqlite3"); return ``root``.
    ``duration`` (s): each roll-out's times scaled so that it lasts that long (``time_from_start``
    and the messages' stamps: the robot's pace for ``ros2 bag play``; ``acnmp.duration`` in the
    metadata); None: the recorded times as they are (the phase). Times are whole nanoseconds in a
    bag (``builtin_interfaces/Duration``): each is rounded to the nearest, so read back they are
    within 0.5 ns of the recorded ones. Written in a temporary directory beside ``root`` and
    renamed into place: a failure leaves nothing. DatasetError for roll-outs that do not fit
    together, a ``root`` that is not new, an unknown storage or a duration that is not > 0."""
    rosbag2, _ = _rosbags()
    root = Path(root)
    if storage not in STORAGES:
        raise DatasetError(root, f"storage {storage!r} (expected one of {', '.join(STORAGES)})")
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise DatasetError(root, f"duration {duration!r} (expected seconds > 0)")
    if root.exists() and (not root.is_dir() or any(root.iterdir())):
        raise DatasetError(root, "already exists (expected a new or empty directory for the bags)")
    d, p = check_rollouts(rollouts, str(root))
    names, param_names = rollout_names(rollouts, d, p)
    store = typestore()
    plugin = rosbag2.StoragePlugin.MCAP if storage == "mcap" else rosbag2.StoragePlugin.SQLITE3
    with new_directory(root) as tmp:
        start = 0
        for i, r in enumerate(rollouts):
            if r.wall_time is not None:
                start = max(start, int(r.wall_time * 1e9))
            scale = 1.0 if duration is None else duration / float(r.times[-1] - r.times[0])
            with rosbag2.Writer(tmp / f"rollout_{i:04d}", version=9, storage_plugin=plugin) as writer:
                _write_rollout(writer, store, r, start, names, param_names, scale)
                if duration is not None:
                    writer.set_custom_data(f"{META_PREFIX}duration", json.dumps(float(duration)))
            start += int(math.ceil(float(r.times[-1] - r.times[0]) * scale + 1.0) * 1e9)  # the next one after it
    return root


def _write_rollout(writer, store, r: RolloutEpisode, start: int, names: list[str], param_names: list[str],
                   scale: float = 1.0) -> None:
    """One roll-out's messages (its times, multiplied by ``scale``, from ``start`` ns) and metadata into an open Writer."""
    t = store.types
    time_msg, duration = t["builtin_interfaces/msg/Time"], t["builtin_interfaces/msg/Duration"]

    def stamp(ns: int):
        return time_msg(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    offsets = [int(round(float(x - r.times[0]) * scale * 1e9)) for x in r.times]
    header = t["std_msgs/msg/Header"](stamp=stamp(start), frame_id="")
    point = t["trajectory_msgs/msg/JointTrajectoryPoint"]
    empty = np.zeros(0, dtype=np.float64)
    traj = t["trajectory_msgs/msg/JointTrajectory"](header=header, joint_names=list(names), points=[
        point(positions=np.asarray(row, dtype=np.float64), velocities=empty, accelerations=empty, effort=empty,
              time_from_start=duration(sec=off // 1_000_000_000, nanosec=off % 1_000_000_000))
        for row, off in zip(r.trajectory, offsets)])
    conns = {topic: writer.add_connection(topic, kind, typestore=store) for topic, kind in (
        (TRAJECTORY_TOPIC, "trajectory_msgs/msg/JointTrajectory"), (PARAMS_TOPIC, "std_msgs/msg/Float64MultiArray"),
        (REWARD_TOPIC, "std_msgs/msg/Float64"), (SUCCESS_TOPIC, "std_msgs/msg/Bool"))}

    def put(topic: str, ns: int, msg) -> None:
        writer.write(conns[topic], ns, store.serialize_cdr(msg, msgtype(msg)))

    put(TRAJECTORY_TOPIC, start, traj)
    dim = t["std_msgs/msg/MultiArrayDimension"](label=",".join(param_names), size=len(r.task_params),
                                                 stride=len(r.task_params))
    put(PARAMS_TOPIC, start, t["std_msgs/msg/Float64MultiArray"](
        layout=t["std_msgs/msg/MultiArrayLayout"](dim=[dim], data_offset=0),
        data=np.asarray(r.task_params, dtype=np.float64)))
    for off, reward in zip(offsets, np.asarray(r.reward, dtype=np.float64)):
        put(REWARD_TOPIC, start + off, t["std_msgs/msg/Float64"](data=float(reward)))
    put(SUCCESS_TOPIC, start + offsets[-1], t["std_msgs/msg/Bool"](data=bool(r.success)))
    meta = {"job": r.job, "method": r.method, "skill": r.skill, "robot": r.robot, "task": r.task,
            "rollout_index": json.dumps(int(r.rollout_index)), "success": json.dumps(bool(r.success)),
            "return": json.dumps(float(r.ret)),
            "task_params": json.dumps(np.asarray(r.task_params, dtype=np.float64).tolist()),
            "task_param_names": json.dumps(param_names), "value_names": json.dumps(names)}
    for key, value in meta.items():
        writer.set_custom_data(f"{META_PREFIX}{key}", value)
