"""Numbers out of ROS messages by a path, as ``acnmp demos import --format rosbag2`` takes them.

A reference is ``TOPIC[:PATH][@first|@last]``: the topic, then a path of fields separated by dots,
each field optionally followed by a selector in brackets:

- ``[i]``, ``[i:j]``: components of a numeric array (Python's rules);
- ``[name,name]``: components by name, looked up in the names the message gives them
  (``sensor_msgs/JointState``'s ``name``, ``trajectory_msgs/JointTrajectory``'s ``joint_names``);
- ``[*]``: every element of a sequence of messages, each a row of its own (a JointTrajectory's
  ``points[*].positions``: one row per point, at the message's time plus the point's
  ``time_from_start``).

A path that ends on a message flattens its numeric fields (``pose.position`` of a PoseStamped
gives x, y, z). Without a path, a JointState gives its ``position`` and a JointTrajectory its
``points[*].positions``; any other type needs one. ``@first``/``@last`` (task parameters only) take
the first or last message of the episode. :func:`extract` evaluates a path on one message (the
message objects of rosbags: dataclasses with ``__msgtype__``); nothing here reads a bag.
"""
from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

import numpy as np

_SEGMENT = re.compile(r"^(?P<field>[A-Za-z_]\w*)(?:\[(?P<sel>[^\[\]]*)\])?$")
_INDEX = re.compile(r"^-?\d+$")
_SLICE = re.compile(r"^(?P<a>-?\d*):(?P<b>-?\d*)$")
#: the path a reference without one takes, by message type
DEFAULT_PATHS = {
    "sensor_msgs/msg/JointState": "position",
    "trajectory_msgs/msg/JointTrajectory": "points[*].positions",
}
#: the fields that name the components of a message's arrays (JointState, JointTrajectory, ...)
NAME_FIELDS = ("name", "joint_names")


class PathError(ValueError):
    """A path that does not fit the message: the message is one line saying what was expected."""


@dataclass(frozen=True)
class Segment:
    """One field of a path and its selector: None (all), "*" (every element), an index or slice
    (``(start, stop)``), or names."""

    field: str
    select: str | tuple[int | None, int | None] | tuple[str, ...] | None = None


@dataclass(frozen=True)
class MessageRef:
    """A reference as written: ``topic``, the ``path`` (empty: the type's default), ``at``
    ("first", "last" or None) and the ``text`` itself (for messages and names)."""

    topic: str
    path: tuple[Segment, ...]
    at: str | None
    text: str


def parse_ref(text: str, *, task_param: bool = False) -> MessageRef:
    """A :class:`MessageRef` from ``TOPIC[:PATH][@first|@last]``; ValueError naming the text when
    it is malformed (``@first``/``@last`` only with ``task_param``)."""
    body, at = text.strip(), None
    for suffix in ("@first", "@last"):
        if body.endswith(suffix):
            body, at = body[: -len(suffix)], suffix[1:]
    topic, _, path = body.partition(":")
    form = "TOPIC[:FIELD[.FIELD...]], a field optionally [i], [i:j], [name,...] or [*]"
    if at and not task_param:
        raise ValueError(f"{text!r}: @{at} is for task parameters (expected {form})")
    if not topic.startswith("/") or any(c in topic for c in "[]@ "):
        raise ValueError(f"{text!r}: not a topic reference (expected {form}, the topic starting with /)")
    segments = []
    for part in _split_path(path) if path else []:
        m = _SEGMENT.match(part)
        if not m:
            raise ValueError(f"{text!r}: {part!r} is not a field (expected {form})")
        segments.append(Segment(m["field"], _selector(m["sel"], text)))
    return MessageRef(topic, tuple(segments), at, text.strip())


def _split_path(path: str) -> list[str]:
    """``a.b[x.y].c`` split on the dots outside brackets."""
    out, depth, cur = [], 0, ""
    for ch in path:
        depth += (ch == "[") - (ch == "]")
        if ch == "." and depth == 0:
            out.append(cur)
            cur = ""
        else:
            cur += ch
    return [*out, cur]


def _selector(sel: str | None, text: str):
    if sel is None:
        return None
    sel = sel.strip()
    if sel == "*":
        return "*"
    if _INDEX.match(sel):
        i = int(sel)
        return (i, i + 1 if i != -1 else None)
    m = _SLICE.match(sel)
    if m:
        return (int(m["a"]) if m["a"] else None, int(m["b"]) if m["b"] else None)
    names = tuple(n.strip() for n in sel.split(","))
    if not all(names):
        raise ValueError(f"{text!r}: [{sel}] is not a selector (expected [i], [i:j], [name,...] or [*])")
    return names


def msgtype(msg) -> str:
    """The ROS type of a message object (``pkg/msg/Name``)."""
    return getattr(msg, "__msgtype__", type(msg).__name__)


def _fields(msg) -> list[str]:
    return [f.name for f in dataclasses.fields(msg) if f.name != "__msgtype__"]


def _is_message(value) -> bool:
    return dataclasses.is_dataclass(value) and not isinstance(value, type)


def _number(value) -> bool:
    return isinstance(value, (bool, int, float, np.number, np.bool_))


def _flatten(msg, prefix: str) -> tuple[list[float], list[str]]:
    """The numeric fields of ``msg``, nested messages included (headers and strings left out)."""
    values, names = [], []
    for name in _fields(msg):
        value = getattr(msg, name)
        if name == "header" or isinstance(value, str):
            continue
        if _is_message(value):
            v, n = _flatten(value, f"{prefix}{name}.")
        elif _number(value):
            v, n = [float(value)], [f"{prefix}{name}"]
        elif isinstance(value, np.ndarray) and value.dtype.kind in "fiub" and value.ndim == 1:
            v, n = value.astype(np.float64).tolist(), [f"{prefix}{name}[{i}]" for i in range(len(value))]
        else:
            continue
        values += v
        names += n
    return values, names


def _duration(value) -> float | None:
    """A builtin_interfaces Duration in seconds (None for anything else)."""
    if _is_message(value) and msgtype(value) == "builtin_interfaces/msg/Duration":
        return int(value.sec) + int(value.nanosec) * 1e-9
    return None


def path_of(ref: MessageRef, type_name: str) -> tuple[Segment, ...]:
    """The path ``ref`` takes on messages of ``type_name``: its own, else the type's default;
    PathError for a type without a default."""
    if ref.path:
        return ref.path
    default = DEFAULT_PATHS.get(type_name)
    if default is None:
        raise PathError(f"is of type {type_name}, which has no default field (expected {ref.topic}:FIELD, "
                        "e.g. a numeric field or a message of them)")
    return parse_ref(f"{ref.topic}:{default}").path


def extract(msg, path: tuple[Segment, ...]) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The numbers ``path`` selects in ``msg``: rows (R, k) float64 (R > 1 only through a ``[*]``),
    each row's offset from the message's time (R,) in seconds (an element's ``time_from_start``,
    else 0), and the k component names. PathError (one line) for a field the type lacks, a
    selector that does not fit, a name the message does not give, or a value that is not numeric."""
    return _walk(msg, path, 0, None, "")


def _walk(value, path, i, names_from, where):
    if _is_message(value):
        for key in NAME_FIELDS:
            given = getattr(value, key, None)
            if isinstance(given, list) and all(isinstance(n, str) for n in given):
                names_from = given
    if i == len(path):
        return _leaf(value, where, names_from)
    seg = path[i]
    if not _is_message(value):
        raise PathError(f"{where or 'the message'} is not a message (expected no field {seg.field!r} after it)")
    if seg.field not in _fields(value):
        raise PathError(f"{msgtype(value)} has no field {seg.field!r} (expected one of {', '.join(_fields(value))})")
    child, here = getattr(value, seg.field), f"{where}.{seg.field}" if where else seg.field
    if isinstance(child, list) and child and _is_message(child[0]) or (isinstance(child, list) and seg.select == "*"):
        return _elements(child, seg, path, i, names_from, here)
    if seg.select == "*":
        raise PathError(f"{here} is not a sequence of messages (expected [*] only there)")
    rows, offsets, names = _walk(child, path, i + 1, names_from, here)
    if seg.select is None:
        return rows, offsets, names
    if i + 1 < len(path):
        raise PathError(f"{here}[...] selects components: only on the last field (expected it at the end)")
    picked, labels = _select(rows, names, seg.select, names_from, here)
    return picked, offsets, labels


def _elements(items: list, seg: Segment, path, i, names_from, here):
    if seg.select != "*" and seg.select is not None and not (isinstance(seg.select, tuple) and
                                                             all(isinstance(s, (int, type(None))) for s in seg.select)):
        raise PathError(f"{here} is a sequence of messages (expected [*], [i] or [i:j] on it)")
    chosen = items if seg.select in ("*", None) else items[slice(*seg.select)]
    if seg.select is None and len(items) != 1:
        raise PathError(f"{here} is a sequence of {len(items)} messages (expected [*] for one row each, or [i])")
    rows, offsets, names = [], [], None
    for item in chosen:
        r, o, n = _walk(item, path, i + 1, names_from, f"{here}[*]")
        start = _duration(getattr(item, "time_from_start", None)) or 0.0
        rows.append(r)
        offsets.append(o + start)
        names = names or n
    if not rows:
        raise PathError(f"{here} is empty (expected at least one element)")
    widths = {r.shape[1] for r in rows}
    if len(widths) > 1:
        raise PathError(f"{here}[*] gives rows of different lengths {sorted(widths)} (expected one length)")
    return np.concatenate(rows), np.concatenate(offsets), names


def _leaf(value, where: str, names_from):
    if _number(value):
        return np.array([[float(value)]]), np.zeros(1), [where]
    if isinstance(value, np.ndarray) and value.dtype.kind in "fiub" and value.ndim == 1:
        names = list(names_from) if names_from is not None and len(names_from) == len(value) else \
            [f"{where}[{j}]" for j in range(len(value))]
        return value.astype(np.float64).reshape(1, -1), np.zeros(1), names
    if _is_message(value):
        values, names = _flatten(value, f"{where}." if where else "")
        if values:
            return np.array([values]), np.zeros(1), names
        raise PathError(f"{where or 'the message'} ({msgtype(value)}) has no numeric field (expected numbers)")
    kind = "text" if isinstance(value, str) else type(value).__name__
    raise PathError(f"{where} is {kind} (expected a number, an array of numbers or a message of them)")


def _select(rows: np.ndarray, names: list[str], select, names_from, where: str):
    if isinstance(select, tuple) and select and isinstance(select[0], str):
        if names_from is None or len(names_from) != rows.shape[1]:
            raise PathError(f"{where}: no names for its {rows.shape[1]} components (expected a message with "
                            f"{' or '.join(NAME_FIELDS)} of that length; select by [i] or [i:j])")
        missing = [n for n in select if n not in names_from]
        if missing:
            raise PathError(f"{where}: no component named {missing[0]!r} (expected one of {', '.join(names_from)})")
        idx = [names_from.index(n) for n in select]
        return rows[:, idx], list(select)
    picked = rows[:, slice(*select)]
    if picked.shape[1] == 0:
        raise PathError(f"{where}: the selector selects none of its {rows.shape[1]} components (expected at least one)")
    return picked, names[slice(*select)]
