"""One recording in several files: ``run.rrd``, then ``run.1.rrd``, ``run.2.rrd``, ... (its segments).

A Rerun file cannot be appended to (its sink truncates the file and ends it with a footer), and a
recorder killed with -9 leaves a file without footer. So a recording is **never rewritten**: a
recorder restarted by the launcher, and a deployment started again with the same ``--record``
path (after a stop, or after its launcher was killed), write the next free segment,
``<stem>.<n><suffix>``, with the same application id and recording id as the first file. That is
Rerun's own convention for one recording in several files ("Recordings": the viewer pools data by
application and recording id, so ``rerun run.rrd run.*.rrd`` shows one recording), and the one the
recorder already followed for its restarts. Readers here take a recording's segments together:
:func:`recording_segments` lists them, ``acnmp replay run.rrd`` (:func:`services.recording.replay.summarize`,
:func:`services.recording.tables.read_recording`) reads them all. The recorder of a new segment is
given the earlier ones (``--seen``), so an event or a learner's roll-out they hold is not written
again: a roll-out journalled before a kill and published again after the restart is in the
recording once.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

#: The Rerun application id of every recording the recorder writes (services/recording/rrd_writer.py).
APPLICATION_ID = "acnmp"


def _segment_pattern(first: Path) -> re.Pattern:
    return re.compile(rf"^{re.escape(first.stem)}\.(\d+){re.escape(first.suffix)}$")


def recording_segments(first: str | Path) -> list[Path]:
    """The files of the recording whose first file is ``first``: ``first`` itself and its segments
    ``<stem>.<n><suffix>`` (n >= 1), in segment order, each only when it exists and is not empty."""
    first = Path(first)
    pattern = _segment_pattern(first)
    found = [(0, first)] if first.is_file() and first.stat().st_size > 0 else []
    if first.parent.is_dir():
        for p in first.parent.iterdir():
            m = pattern.match(p.name)
            if m and int(m.group(1)) >= 1 and p.is_file() and p.stat().st_size > 0:
                found.append((int(m.group(1)), p))
    return [p for _, p in sorted(found)]


def next_segment(first: str | Path, taken: tuple[Path, ...] | list[Path] = ()) -> Path:
    """Where the recording whose first file is ``first`` continues: ``first`` while it does not exist
    or is empty (and is not ``taken``: files this deployment already writes or wrote), else the
    segment after the highest one there or taken (``<stem>.<n+1><suffix>``)."""
    first = Path(first)
    taken = [Path(p) for p in taken]
    if not (first.is_file() and first.stat().st_size > 0) and first not in taken:
        return first
    pattern = _segment_pattern(first)
    names = [p.name for p in first.parent.iterdir()] + [p.name for p in taken]
    numbers = [int(m.group(1)) for name in names if (m := pattern.match(name))]
    return first.with_name(f"{first.stem}.{max(numbers, default=0) + 1}{first.suffix}")


@dataclass(frozen=True)
class RecordingIdentity:
    """What makes files one recording for Rerun: the application id and the recording id."""

    application_id: str
    recording_id: str


def recording_identity(files: list[Path], application_id: str = APPLICATION_ID) -> RecordingIdentity:
    """The identity of the recording held by ``files`` (its segments, first first): that of the first
    file Rerun can read. ValueError (one line naming the file and the choices) when none can be
    read, or when the recording is another application's (not ``application_id``): a new segment
    would not join it."""
    import rerun as rr

    why = "it holds no recording"
    for path in files:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a file without footer makes Rerun warn
                stores = rr.chunk.RrdReader(path).recordings()
        except Exception as exc:
            why = f"not a readable .rrd ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})"
            continue
        if not stores:
            continue
        store = stores[0]
        if store.application_id != application_id:
            raise ValueError(f"{files[0]}: a recording of application {store.application_id!r}, not an ACNMP "
                             f"deployment's ({application_id!r}); give another file (a deployment continues its own "
                             "recording in a next segment, it never overwrites one)")
        return RecordingIdentity(store.application_id, store.recording_id)
    raise ValueError(f"{files[0]}: exists but {why}; give another file or move it away (a deployment continues "
                     "its own recording in a next segment, it never overwrites one)")
