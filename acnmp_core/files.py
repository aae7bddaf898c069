"""Writing a file so that a crash, a full disk or a power cut never leaves half of it.

:func:`atomic_write_bytes` writes to a temporary file in the target's directory
(``.<name>.<random>.tmp``, see :data:`TEMP_SUFFIX`), flushes and fsyncs it, renames it over the
target and fsyncs the directory, so the target holds either its old content or the new one, and
the new one survives a power cut once the call returns. A failed write (``ENOSPC``, ``EIO``,
permission) removes the temporary file and raises the ``OSError``; the target is untouched. A
process killed in the middle leaves only its temporary file, which :func:`stale_temp_files` finds.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

#: Suffix of the temporary files :func:`atomic_write_bytes` writes (their names start with a dot).
TEMP_SUFFIX = ".tmp"


def atomic_write_bytes(path: str | os.PathLike, data: bytes, *, durable: bool = True) -> Path:
    """Replace ``path`` with ``data`` atomically; returns the path.

    ``durable`` (default) fsyncs the file before the rename and the directory after it; without
    it the write is still atomic but may be lost (not torn) by a power cut. Raises OSError (the
    target unchanged, no temporary file left).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=TEMP_SUFFIX)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            if durable:
                os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    if durable:
        fsync_directory(path.parent)
    return path


def fsync_directory(directory: str | os.PathLike) -> None:
    """fsync ``directory`` itself, so a rename or removal in it survives a power cut (a no-op where
    directories cannot be opened, e.g. on Windows)."""
    try:
        fd = os.open(directory, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except (PermissionError, IsADirectoryError):
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def is_temp_file(path: str | os.PathLike) -> bool:
    """Whether ``path`` is named like a temporary file of :func:`atomic_write_bytes` (or of the
    writers before it: any name ending in :data:`TEMP_SUFFIX`)."""
    return Path(path).name.endswith(TEMP_SUFFIX)


def stale_temp_files(directory: str | os.PathLike) -> list[Path]:
    """The temporary files directly in ``directory`` (none if it does not exist), sorted. Only
    the caller knows whether their writers are dead (e.g. it holds the directory's lock)."""
    directory = Path(directory)
    if not directory.is_dir():
        return []
    return sorted(p for p in directory.iterdir() if p.is_file() and is_temp_file(p))
