"""The project's demonstration file format (.npz) and its reader and writer.

A demonstration file is a NumPy ``.npz`` archive (``np.savez``; read with ``np.load(path,
allow_pickle=False)``) of the arrays in :data:`FIELDS`, format version 1. N demonstrations of up
to T rows each, D output dimensions (the trajectory's columns), P task parameters. Numeric arrays
of another float or integer dtype are converted on reading; every number must be finite, padding
included. String arrays are fixed-width unicode (``np.array(["a", "b"])``), never object arrays,
so no pickle is involved. Keys not listed are ignored. :func:`save_demos` writes one (atomically,
checked); :func:`load_demos` reads and checks one.
"""
from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UnreadableFileError
from ..files import atomic_write_bytes
from ..validation import check_array

FORMAT_VERSION = 1
_STRING_KEYS = ("task_param_names", "value_names", "roles")


@dataclass(frozen=True)
class Field:
    """One array of a demonstration file: its key, shape, dtype, whether it must be there, and
    what it holds (units included)."""

    key: str
    shape: str
    dtype: str
    required: bool
    meaning: str


#: Every array of the format, in the order the docs list them (docs/ROBOTS.md renders this table).
FIELDS: tuple[Field, ...] = (
    Field("times", "(N, T)", "float64", True,
          "each row's time, strictly increasing along a demonstration's valid rows; the project uses the "
          "phase in [0, 1] (any unit is allowed; use the same for every demonstration and every query)"),
    Field("values", "(N, T, D)", "float64", True,
          "the trajectories in raw units (e.g. joint angles in rad, positions in m): row k of "
          "demonstration i is its D values at times[i, k] (a Gymnasium robot tracks one row per environment "
          "step)"),
    Field("task_params", "(N, P)", "float64", True,
          "each demonstration's task parameters in the task's units (e.g. a goal's x, y in m), in the "
          "order test points (`--at`) and adapt requests give them; P may be 0: np.zeros((N, 0))"),
    Field("lengths", "(N,)", "int64", False,
          "valid rows per demonstration, each in [2, T]: demonstrations of different lengths share one "
          "array; the rows from lengths[i] on are padding, never read, but finite (e.g. the last row "
          "repeated); without it every row is valid"),
    Field("value_names", "(D,)", "str", False, "a name per output dimension, e.g. the joints'"),
    Field("task_param_names", "(P,)", "str", False, "a name per task parameter"),
    Field("roles", "(N,)", "str", False,
          "a role per demonstration, e.g. \"train\", \"interpolation\", \"extrapolation\""),
    Field("format_version", "()", "int64", False, f"{FORMAT_VERSION}, this format (absent: {FORMAT_VERSION})"),
)


def format_table() -> str:
    """:data:`FIELDS` as a Markdown table (key, shape, dtype, required, meaning)."""
    rows = [f"| `{f.key}` | {f.shape} | {f.dtype} | {'yes' if f.required else 'no'} | {f.meaning} |" for f in FIELDS]
    return "\n".join(["| key | shape | dtype | required | meaning |", "| --- | --- | --- | --- | --- |", *rows])


def format_help() -> str:
    """The format in a few lines for a command's ``--help`` (the arrays, their shapes, an example)."""
    lines = ["demonstration file (FILE.npz as np.savez writes it; docs/ROBOTS.md, \"The demonstration file\"):",
             "N demonstrations of T rows, D outputs (the trajectory's columns), P task parameters",
             *(f"  {f.key:<17} {f.shape:<10} {f.dtype:<8} {'required' if f.required else 'optional'}" for f in FIELDS),
             "  values in raw units (e.g. rad), times strictly increasing (phase 0..1), padding past lengths[i]",
             "example: np.savez(\"demos.npz\", times=np.tile(np.linspace(0, 1, 100), (7, 1)), values=q,  # q (7, 100, 3)",
             "                  task_params=goals)  # goals (7, 2)"]
    return "\n".join(lines)


@dataclass
class DemoArrays:
    """A demonstration set as arrays (see the module docstring for the shapes).

    ``demo(i)`` returns demonstration ``i`` trimmed to its length: times (T_i,), values (T_i, D),
    task_params (P,).
    """

    times: np.ndarray
    values: np.ndarray
    task_params: np.ndarray
    task_param_names: np.ndarray | None = None
    value_names: np.ndarray | None = None
    roles: np.ndarray | None = None
    lengths: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.values = check_array("values", self.values, ndim=3, min_size=1)
        n, t, d = self.values.shape
        self.times = check_array("times", self.times, shape=(n, t))
        self.task_params = check_array("task_params", self.task_params, ndim=2)
        if self.task_params.shape[0] != n:
            raise ValueError(f"task_params: expected {n} rows (one per demonstration), got {self.task_params.shape[0]}")
        if self.lengths is None:
            lengths = np.full(n, t, dtype=np.int64)
        else:
            lengths = check_array("lengths", self.lengths, shape=(n,), dtype=np.int64)
            if np.any(lengths < 2) or np.any(lengths > t):
                raise ValueError(f"lengths: expected every length in [2, {t}], got {lengths.tolist()}")
        for i in range(n):
            if np.any(np.diff(self.times[i, : lengths[i]]) <= 0):
                raise ValueError(f"times: row {i} is not strictly increasing")
        self.lengths = None if self.lengths is None else lengths
        want = {"task_param_names": self.task_params.shape[1], "value_names": d, "roles": n}
        for key in _STRING_KEYS:
            arr = getattr(self, key)
            if arr is None:
                continue
            arr = np.asarray(arr)
            if arr.dtype.kind not in "US":
                raise ValueError(f"{key}: expected an array of strings, got dtype {arr.dtype}")
            arr = arr.astype(str)
            if arr.shape != (want[key],):
                raise ValueError(f"{key}: expected shape ({want[key]},), got {arr.shape}")
            setattr(self, key, arr)

    def __len__(self) -> int:
        return self.values.shape[0]

    def length(self, i: int) -> int:
        """Number of valid rows of demonstration ``i``."""
        return int(self.values.shape[1] if self.lengths is None else self.lengths[i])

    def demo(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(times (T_i,), values (T_i, D), task_params (P,)) of demonstration ``i``."""
        k = self.length(i)
        return self.times[i, :k], self.values[i, :k], self.task_params[i]

    def select(self, idx) -> "DemoArrays":
        """A new DemoArrays with the rows ``idx`` (a sequence of indices or a boolean mask)."""
        idx = np.arange(len(self))[np.asarray(idx)]

        def take(a):
            return None if a is None else a[idx]

        return DemoArrays(self.times[idx], self.values[idx], self.task_params[idx], self.task_param_names,
                          self.value_names, take(self.roles), take(self.lengths))

    def with_role(self, role: str) -> "DemoArrays":
        """The demonstrations whose ``roles`` entry equals ``role`` (ValueError without roles)."""
        if self.roles is None:
            raise ValueError("role: this demonstration set has no roles")
        return self.select(self.roles == role)

    def to_demo_set(self):
        """The same data as an :class:`acnmp_core.data.demos.DemoSet` (imports torch via that module)."""
        from .demos import DemoSet, Demonstration

        return DemoSet([Demonstration(*self.demo(i)) for i in range(len(self))])


def demos_bytes(demos: DemoArrays) -> bytes:
    """The bytes of the .npz file :func:`save_demos` writes for ``demos`` (for a caller that
    writes them its own way, e.g. services/learner/store.py)."""
    arrays = {
        "format_version": np.array(FORMAT_VERSION, dtype=np.int64),
        "times": demos.times,
        "values": demos.values,
        "task_params": demos.task_params,
    }
    if demos.lengths is not None:
        arrays["lengths"] = np.asarray(demos.lengths, dtype=np.int64)
    for key in _STRING_KEYS:
        if getattr(demos, key) is not None:
            arrays[key] = np.asarray(getattr(demos, key), dtype=str)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def save_demos(path: str | os.PathLike, demos: DemoArrays) -> Path:
    """Write ``demos`` to ``path`` (.npz) atomically and durably (acnmp_core/files.py) and return
    the path. Raises OSError when it cannot be written (``path`` is then unchanged)."""
    return atomic_write_bytes(path, demos_bytes(demos))


#: The first bytes of a zip archive (an .npz is one): a local file header, or an empty archive's end.
ZIP_MAGICS = (b"PK\x03\x04", b"PK\x05\x06")
#: Why :func:`load_demos` refuses an archive it cannot unpack.
TRUNCATED = "not a readable demonstrations .npz (truncated or damaged)"


def load_demos(path: str | os.PathLike) -> DemoArrays:
    """Read a demonstration file written by :func:`save_demos` (or by hand in the same format).

    Raises :class:`~acnmp_core.errors.UnreadableFileError` (a ValueError; ``reason`` says what is
    wrong without the path) for a file that cannot be read, one that is not an .npz archive ("not
    a demonstrations .npz: PATH"), a truncated archive, a missing key, an unknown format version,
    or arrays that do not fit together.
    """
    where = os.fspath(path)
    try:
        with open(path, "rb") as f:
            magic = f.read(4)
        npz = np.load(path, allow_pickle=False) if magic in ZIP_MAGICS else None
    except OSError as exc:
        raise UnreadableFileError(path, f"cannot be read ({exc.strerror or exc})",
                                  f"path: cannot read a demonstration file at {where!r} ({exc})") from None
    except Exception:  # zipfile's and numpy's errors for a damaged archive
        raise UnreadableFileError(path, TRUNCATED, f"path: {where} is {TRUNCATED}") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):  # text, a single .npy array, a pickle: numpy's
        reason = "not a demonstrations .npz"  # words would mislead
        raise UnreadableFileError(path, reason, f"path: {reason}: {where}")
    with npz:
        missing = [k for k in ("times", "values", "task_params") if k not in npz.files]
        if missing:
            raise UnreadableFileError(path, f"lacks the key(s) {missing}", f"path: {where!r} lacks the key(s) {missing}")
        try:
            version = int(npz["format_version"]) if "format_version" in npz.files else FORMAT_VERSION
            opt = {k: npz[k] for k in (*_STRING_KEYS, "lengths") if k in npz.files}
            arrays = (npz["times"], npz["values"], npz["task_params"])
        except ValueError as exc:  # e.g. an object array, which would need pickle
            reason = f"holds an array this format does not allow ({exc})"
            raise UnreadableFileError(path, reason, f"path: {where!r} {reason}") from None
        except Exception:  # a member cut short or damaged (zlib, zipfile, EOF errors)
            raise UnreadableFileError(path, TRUNCATED, f"path: {where} is {TRUNCATED}") from None
        if version != FORMAT_VERSION:
            reason = f"format_version {version} is not supported (expected {FORMAT_VERSION})"
            raise UnreadableFileError(path, reason, f"path: {reason}")
        try:
            return DemoArrays(*arrays, **opt)
        except ValueError as exc:
            raise UnreadableFileError(path, f"arrays that do not fit together ({exc})",
                                      f"path: {where}: {exc}") from None


__doc__ += "\n" + format_table() + "\n"  # help(acnmp_core.data.demo_io) shows the format, from FIELDS
