"""The learner's durable state: skills (model + demonstrations) and jobs, under one directory.

Layout of ``<state_dir>`` (docs/STATE.md tells the same story to an
operator)::

    skills/<skill>/model-v<N>.pt          checkpoint of version N (acnmp_core.model.checkpoint); meta:
                                          version, demos file, n_demos, source_hash, trained_as,
                                          partner files
    skills/<skill>/demos-v<N>.npz         its demonstrations (acnmp_core.data.demo_io, padded + lengths)
    skills/<skill>/partner-v<N>.pt        a paired skill's robot B model
    skills/<skill>/partner-demos-v<N>.npz and robot B's demonstrations
    skills/<skill>/versions.json          {"format": 1, "skill", "highest"}: the highest version
                                          ever committed (a durable high-water mark)
    jobs/<job>.json                       one job record (services/learner/jobs.py)
    quarantine/<UTC time>/<path>          a file found unusable at a start, moved aside, and
    quarantine/<UTC time>/<path>.why      one line saying why

**Writing.** Every file is written through :func:`acnmp_core.files.atomic_write_bytes`: a temp
file in the same directory, fsynced, renamed over the target, the directory fsynced; a reader
sees the old file or the new one, and the new one survives a power cut once the write returned.
A write that fails (disk full, I/O error, permission) raises :class:`StateWriteError` ("no space
left on device while saving skill e1 version 3 to ...") and leaves nothing half-done: a skill
version's files written so far are removed again.

**Versions are never reused.** A version's files carry its number; its checkpoint is the commit
point (demonstrations and partner files are written first, then ``model-v<N>.pt``, then
``versions.json``). The newest ``keep_versions`` checkpoints are kept (older versions' files are
removed), so a latest version that cannot be read falls back to the one before. The next version
of a skill is one above the highest number found anywhere: ``versions.json``, the names of its
files, the names of its quarantined files, and (the learner adds them) the versions job records
name.

**Start-up.** With the state directory locked (no other writer lives), temp files of dead writers
are removed; every file is read and checked (a checkpoint's meta against its name, the
demonstrations' content hash against the checkpoint's record); a file that cannot be used is
**quarantined** (:meth:`StateDir.quarantine`): moved to ``quarantine/<time>/<its path>``
beside a ``.why`` file with the reason, and logged in one line naming both. A skill whose newest
version is unusable is served from its newest usable one, with a warning. Demonstrations of a
version whose checkpoint is missing are removed when ``versions.json`` shows that version was
never committed (a commit cut short by a crash), quarantined otherwise.
"""
from __future__ import annotations

import json
import logging
import os
import re
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from acnmp_core.data.demo_io import DemoArrays, demos_bytes, load_demos
from acnmp_core.data.demos import DemoSet
from acnmp_core.errors import UnreadableFileError
from acnmp_core.files import atomic_write_bytes, fsync_directory, stale_temp_files
from services.transport.keys import check_name
from services.transport.wire import WireError, decode, encode

from .jobs import JobRecord, RecordFormatError

if TYPE_CHECKING:  # torch: imported by the methods that read or write a checkpoint, so the state
    # directory's mechanics (StateDir, quarantine) serve `acnmp up` and the launcher without it
    from acnmp_core.model.cnmp import CNMP

log = logging.getLogger(__name__)

#: Where unusable files go, under the state directory; the reason file beside each ends so.
QUARANTINE = "quarantine"
REASON_SUFFIX = ".why"
#: A skill's durable high-water mark, and the format of that file.
VERSIONS_FILE = "versions.json"
VERSIONS_FORMAT = 1
#: Checkpoints kept per skill (the newest ones); older versions' files are removed.
DEFAULT_KEEP_VERSIONS = 3
_VERSIONED = re.compile(r"^(model|demos|partner|partner-demos)-v(\d+)\.(pt|npz)$")
LEGACY_CHECKPOINT = "model.pt"  # the layout before per-version checkpoints: one checkpoint per skill


class StateWriteError(RuntimeError):
    """A state file could not be written (disk full, I/O error, permission denied); the file is as it
    was. The message says what, why and where: ``no space left on device while saving skill e1
    version 3 to /state/skills/e1/model-v3.pt``; ``errno`` is the OS error's."""

    def __init__(self, what: str, path: str | os.PathLike, exc: OSError):
        why = exc.strerror or str(exc)
        super().__init__(f"{why[:1].lower()}{why[1:]} while saving {what} to {path}")
        self.what, self.path, self.errno = what, Path(path), exc.errno


@dataclass(frozen=True)
class Quarantined:
    """A file moved aside: where it was and where it is now (both relative to the state
    directory), and why."""

    path: str
    moved_to: str
    reason: str

    def line(self) -> str:
        """One line for a log, the launcher's output and ``acnmp status``."""
        return f"quarantined {self.path}: {self.reason} (moved to {self.moved_to})"


class StateDir:
    """One state directory: writes that say what failed, quarantine, temp-file clean-up, and
    whether the last write failed (the learner's health).

    ``root`` is created if missing. Quarantined files of this process go under
    ``quarantine/<UTC time of this object's creation>/``.
    """

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root).resolve()
        self.root.mkdir(parents=True, exist_ok=True)
        self._stamp = time.strftime("%Y%m%dT%H%M%SZ", time.gmtime())
        self._lock = threading.Lock()
        self._write_error: str | None = None
        #: files this process quarantined, in order
        self.found: list[Quarantined] = []

    def rel(self, path: str | os.PathLike) -> str:
        """``path`` relative to the state directory (as it is when outside it)."""
        try:
            return str(Path(path).resolve().relative_to(self.root))
        except ValueError:
            return str(path)

    @property
    def write_error(self) -> str | None:
        """The message of the last write, if it failed (None once a write succeeded again)."""
        return self._write_error

    def write(self, path: str | os.PathLike, data: bytes, what: str) -> None:
        """Write ``data`` to ``path`` atomically and durably; :class:`StateWriteError` naming
        ``what`` (e.g. ``skill e1 version 3``) and the path when it cannot."""
        try:
            atomic_write_bytes(path, data)
        except OSError as exc:
            err = StateWriteError(what, path, exc)
            self._write_error = str(err)
            raise err from None
        self._write_error = None

    def quarantine(self, path: str | os.PathLike, reason: str) -> Quarantined:
        """Move ``path`` to ``quarantine/<time>/<its relative path>`` with a ``.why`` file holding
        ``reason``, log one warning line naming both, and return the record. A file that cannot
        be moved stays where it is (the line says so)."""
        path = Path(path)
        rel = self.rel(path)
        dest = self.root / QUARANTINE / self._stamp / rel
        with self._lock:
            n = 1
            while dest.exists():  # the same path twice in one start
                dest = dest.with_name(f"{Path(rel).name}.{n}")
                n += 1
            try:
                dest.parent.mkdir(parents=True, exist_ok=True)
                os.replace(path, dest)
                fsync_directory(path.parent)
            except OSError as exc:
                record = Quarantined(rel, rel, f"{reason}; it could not be moved aside ({exc.strerror or exc})")
                log.error("%s", record.line())
                self.found.append(record)
                return record
            try:  # the reason is a convenience: the log line holds it too
                atomic_write_bytes(dest.with_name(dest.name + REASON_SUFFIX), f"{reason}\n".encode(), durable=False)
            except OSError:
                pass
            record = Quarantined(rel, self.rel(dest), reason)
            self.found.append(record)
        log.warning("%s", record.line())
        return record

    def quarantined(self) -> list[Quarantined]:
        """Every file now under ``quarantine/`` (from any start), oldest first; deleting one there
        takes it off this list."""
        root = self.root / QUARANTINE
        if not root.is_dir():
            return []
        out = []
        for p in sorted(root.rglob("*")):
            if not p.is_file() or p.name.endswith(REASON_SUFFIX):
                continue
            try:
                reason = p.with_name(p.name + REASON_SUFFIX).read_text().strip() or "no reason recorded"
            except OSError:
                reason = "no reason recorded"
            parts = p.relative_to(root).parts
            out.append(Quarantined(str(Path(*parts[1:])) if len(parts) > 1 else parts[0], self.rel(p), reason))
        return out

    def quarantined_names(self, directory: str) -> list[str]:
        """The names of the files quarantined from ``directory`` (relative to the state
        directory, e.g. ``skills/e1``) at any start."""
        root = self.root / QUARANTINE
        if not root.is_dir():
            return []
        return [p.name for stamp in root.iterdir() if (stamp / directory).is_dir() for p in (stamp / directory).iterdir()]

    def remove_stale_temps(self, directory: str | os.PathLike) -> list[str]:
        """Remove the temp files in ``directory`` (call it only while holding the directory's
        lock: their writers are dead then); returns their relative paths."""
        removed = []
        for p in stale_temp_files(directory):
            try:
                p.unlink()
            except OSError as exc:
                log.warning("could not remove %s, a temp file of a writer that died: %s", self.rel(p), exc)
                continue
            removed.append(self.rel(p))
            log.info("removed %s, a temp file of a writer that died", removed[-1])
        return removed


def demo_set_to_arrays(demos: DemoSet, value_names=None, task_param_names=None) -> DemoArrays:
    """Pack a DemoSet (demos may differ in length) into padded DemoArrays with ``lengths``.

    Padding rows repeat each demo's last row; ``DemoArrays.to_demo_set()`` trims them away, so
    the round trip keeps ``content_hash()``.
    """
    n, tmax = len(demos), max(len(d.times) for d in demos)
    times = np.zeros((n, tmax))
    values = np.zeros((n, tmax, demos.n_outputs))
    lengths = np.zeros(n, dtype=np.int64)
    for i, d in enumerate(demos):
        k = len(d.times)
        times[i, :k], values[i, :k], lengths[i] = d.times, d.values, k
        times[i, k:], values[i, k:] = d.times[-1], d.values[-1]
    return DemoArrays(times, values, demos.all_task_params(),
                      task_param_names=None if task_param_names is None else np.asarray(task_param_names, dtype=str),
                      value_names=None if value_names is None else np.asarray(value_names, dtype=str),
                      lengths=lengths)


@dataclass
class SkillState:
    """A skill as the learner holds it: the model, its demonstrations and its version.

    A **paired skill** (a :class:`~acnmp_core.transfer.pair.TransferPair` trained by a ``train_pair``
    job) holds robot A's CNMP and demonstrations as ``model`` and ``demos`` and robot B's as
    ``partner`` and ``partner_demos``; an ordinary skill has neither.
    """

    name: str
    model: CNMP
    demos: DemoSet
    version: int
    partner: CNMP | None = None
    partner_demos: DemoSet | None = None
    #: content hash of the demonstrations the skill was trained from (its version 0, or its last
    #: retraining); kept through assimilations, which add to ``demos``. None: not recorded (a
    #: skill saved before this field existed).
    source_hash: str | None = None
    #: :func:`services.learner.core.train_fingerprint` of the training that made this version
    #: (demonstrations, model, training settings, seed); None for a version an assimilation or a
    #: pair training made, or one saved before this field existed.
    trained_as: str | None = None


class _Unusable(Exception):
    """A file of a skill version that cannot be used: the file and why."""

    def __init__(self, path: Path, reason: str):
        super().__init__(reason)
        self.path, self.reason = path, reason


def reason_of(exc: Exception) -> str:
    """Why a file is unusable, from the error reading it raised (without the file's name when
    the error is an :class:`~acnmp_core.errors.UnreadableFileError`)."""
    return exc.reason if isinstance(exc, UnreadableFileError) else str(exc)


class SkillStore:
    """Saves and loads skills under ``<state_dir>/skills`` (see the module docstring).

    ``state`` : a :class:`StateDir` or its path. ``keep_versions`` : checkpoints kept per skill.
    After :meth:`load_all`, ``notes`` holds one line per skill that was not loaded at its
    newest version (also logged as warnings).
    """

    def __init__(self, state: "StateDir | str | os.PathLike", keep_versions: int = DEFAULT_KEEP_VERSIONS):
        if keep_versions < 1:
            raise ValueError(f"keep_versions: expected >= 1, got {keep_versions}")
        self.state = state if isinstance(state, StateDir) else StateDir(state)
        self.root = self.state.root / "skills"
        self.root.mkdir(parents=True, exist_ok=True)
        self.keep_versions = int(keep_versions)
        self.notes: list[str] = []
        self._highest: dict[str, int] = {}
        #: per skill, the versions a record says were committed (versions.json, a job record), and which
        self._committed: dict[str, dict[int, list[str]]] = {}
        #: per skill, the newest version any of its files (quarantined ones included) had at the start
        self._present: dict[str, int] = {}

    # ----- version numbers -------------------------------------------------------------------
    def highest(self, skill: str) -> int:
        """The highest version of ``skill`` ever committed or named (-1: none)."""
        return self._highest.get(skill, -1)

    def note_version(self, skill: str, version: int, witness: str | None = None) -> None:
        """Count ``version`` of ``skill`` as used: no later version gets its number. ``witness``:
        the record saying that version was committed (``versions.json``, ``job <id>``), for
        :meth:`note_missing`."""
        self._highest[skill] = max(self.highest(skill), int(version))
        if witness is not None:
            self._committed.setdefault(skill, {}).setdefault(int(version), []).append(witness)

    def note_missing(self, served: dict[str, "SkillState"]) -> list[str]:
        """After :meth:`load_all` and the job records' :meth:`note_version` calls: one line per
        skill whose newest committed version (as a record witnesses it) has no file left, not even
        a quarantined one (deleted by hand: nothing else removes a skill's newest version), added
        to ``notes`` and logged. ``served``: the skills loaded, by name. Returns the new lines."""
        lines = []
        for name, committed in sorted(self._committed.items()):
            present = self._present.get(name, -1)
            gone = sorted(v for v in committed if v > present)
            if not gone:
                continue
            who = list(dict.fromkeys(w for v in gone for w in committed[v]))  # versions.json first, then jobs
            what = (f"skill {name}: version(s) {', '.join(map(str, gone))} missing (no file of "
                    f"{'them' if len(gone) > 1 else 'it'} is left; {' and '.join(who)} record"
                    f"{'s' if len(who) == 1 else ''} {'them' if len(gone) > 1 else 'it'} committed); ")
            state = served.get(name)
            if state is not None:
                what += (f"serving version {state.version}, the newest present; its next version will be "
                         f"{self.highest(name) + 1}")
            else:
                what += f"no version of it is served; it is served again once trained, as version {self.highest(name) + 1}"
            lines.append(what)
            log.warning("%s", what)
        self.notes += lines
        return lines

    def next_version(self, skill: str) -> int:
        """Reserve and return the next version number of ``skill`` (one above every number used)."""
        version = self.highest(skill) + 1
        self.note_version(skill, version)
        return version

    # ----- saving ----------------------------------------------------------------------------
    def save(self, skill: "SkillState") -> None:
        """Commit ``skill`` at its version: demonstrations (and robot B's files), then the
        checkpoint (the commit point), then ``versions.json``; then remove versions older than
        the newest ``keep_versions``. :class:`StateWriteError` when a file cannot be written
        before the commit point (the files of this version written so far are removed: nothing
        changed). A failure to update ``versions.json`` after the commit is logged only: the
        checkpoint's name keeps the number."""
        from acnmp_core.model.checkpoint import checkpoint_bytes

        d = self.root / check_name("skill", skill.name)
        v = int(skill.version)
        what = f"skill {skill.name} version {v}"
        written: list[Path] = []

        def put(name: str, data: bytes) -> None:
            self.state.write(d / name, data, what)
            written.append(d / name)

        try:
            demo_file = f"demos-v{v}.npz"
            put(demo_file, demos_bytes(demo_set_to_arrays(skill.demos, skill.model.config.output_names,
                                                          skill.model.config.task_param_names)))
            meta = {"skill": skill.name, "version": v, "demos": demo_file, "n_demos": len(skill.demos)}
            if skill.source_hash is not None:
                meta["source_hash"] = skill.source_hash
            if skill.trained_as is not None:
                meta["trained_as"] = skill.trained_as
            if skill.partner is not None:
                partner_file, partner_demos = f"partner-v{v}.pt", f"partner-demos-v{v}.npz"
                put(partner_demos, demos_bytes(demo_set_to_arrays(skill.partner_demos, skill.partner.config.output_names)))
                put(partner_file, checkpoint_bytes(skill.partner, data_hash=skill.partner_demos.content_hash()))
                meta.update(partner=partner_file, partner_demos=partner_demos)
            put(f"model-v{v}.pt", checkpoint_bytes(skill.model, data_hash=skill.demos.content_hash(), meta=meta))
        except BaseException:
            for path in written:
                try:
                    path.unlink(missing_ok=True)
                except OSError:
                    log.warning("could not remove %s after a failed commit", self.state.rel(path))
            raise
        self.note_version(skill.name, v)
        self._write_versions(d, skill.name)
        self._prune(d)

    def _write_versions(self, d: Path, skill: str) -> None:
        body = {"format": VERSIONS_FORMAT, "skill": skill, "highest": self.highest(skill)}
        try:
            self.state.write(d / VERSIONS_FILE, json.dumps(body).encode(), f"the version record of skill {skill}")
        except StateWriteError as exc:
            log.warning("%s (the names of its checkpoints still keep the number)", exc)

    def _prune(self, d: Path) -> None:
        files = _versioned_files(d)
        kept = sorted((v for v, parts in files.items() if "model" in parts), reverse=True)[:self.keep_versions]
        if not kept:
            return
        for v, parts in files.items():
            if v < kept[-1]:
                for path in parts.values():
                    try:
                        path.unlink(missing_ok=True)
                    except OSError as exc:
                        log.warning("could not remove %s, of an old version: %s", self.state.rel(path), exc)

    # ----- loading ---------------------------------------------------------------------------
    def load_all(self) -> dict[str, "SkillState"]:
        """Every skill, by name, each at its newest usable version; unusable files quarantined
        (see the module docstring). Never raises for a bad file."""
        out = {}
        for d in sorted(p for p in self.root.iterdir() if p.is_dir()):
            try:
                check_name("skill", d.name)
            except ValueError:
                log.warning("ignoring %s: not a skill name", self.state.rel(d))
                continue
            self.state.remove_stale_temps(d)
            state = self._load_skill(d)
            if state is not None:
                out[d.name] = state
        return out

    def _load_skill(self, d: Path) -> "SkillState | None":
        name = d.name
        recorded = self._read_versions(d)
        self._migrate_legacy(d)
        files = _versioned_files(d)
        rel_dir = self.state.rel(d)
        used = [v for v in files] + [int(m.group(2)) for m in map(_VERSIONED.match, self.state.quarantined_names(rel_dir))
                                     if m]
        for v in used:
            self.note_version(name, v)
        if recorded is not None:
            self.note_version(name, recorded, VERSIONS_FILE)
        self._present[name] = max(used, default=-1)
        chosen, unusable = None, []
        for v in sorted((v for v, parts in files.items() if "model" in parts), reverse=True):
            try:
                chosen = self._load_version(d, name, v, files[v])
                break
            except _Unusable as bad:
                unusable.append(v)
                self.state.quarantine(bad.path, bad.reason)
                for path in files[v].values():
                    if path != bad.path and path.exists():
                        self.state.quarantine(path, f"part of version {v} of skill {name}, unusable since "
                                                    f"{bad.path.name} is")
        for v, parts in files.items():  # files of a version whose checkpoint is not there
            if "model" in parts:
                continue
            if recorded is not None and v > recorded:  # never committed: a commit cut short
                for path in parts.values():
                    path.unlink(missing_ok=True)
                    log.info("removed %s: the commit of version %d of skill %s was cut short", self.state.rel(path),
                             v, name)
                continue
            unusable.append(v)
            for path in parts.values():
                self.state.quarantine(path, f"version {v} of skill {name} has no checkpoint (model-v{v}.pt is missing)")
        if unusable:
            lost = ", ".join(map(str, sorted(set(unusable))))
            if chosen is not None:
                note = (f"skill {name}: version(s) {lost} unusable (quarantined); serving version {chosen.version}, "
                        f"the newest usable one; its next version will be {self.highest(name) + 1}")
            else:
                note = (f"skill {name}: no usable version (version(s) {lost} quarantined); it is served again once "
                        f"trained, as version {self.highest(name) + 1}")
            self.notes.append(note)
            log.warning("%s", note)
        if self.highest(name) >= 0 and recorded != self.highest(name):
            self._write_versions(d, name)
        return chosen

    def _read_versions(self, d: Path) -> int | None:
        path = d / VERSIONS_FILE
        if not path.exists():
            return None
        try:
            body = json.loads(path.read_text())
        except (OSError, UnicodeDecodeError, ValueError):
            self.state.quarantine(path, "not a version record (truncated or not JSON)")
            return None
        if not isinstance(body, dict) or body.get("format") != VERSIONS_FORMAT:
            found = body.get("format") if isinstance(body, dict) else None
            self.state.quarantine(path, f"a version record of format {found!r}; this learner reads format "
                                        f"{VERSIONS_FORMAT}")
            return None
        highest = body.get("highest")
        if body.get("skill") != d.name or isinstance(highest, bool) or not isinstance(highest, int) or highest < 0:
            self.state.quarantine(path, f"not a version record of skill {d.name} (skill {body.get('skill')!r}, "
                                        f"highest {highest!r})")
            return None
        return highest

    def _migrate_legacy(self, d: Path) -> None:
        """The layout before per-version checkpoints (one ``model.pt``): renamed to
        ``model-v<N>.pt``, or quarantined when it cannot be read."""
        from acnmp_core.model.checkpoint import load_checkpoint

        legacy = d / LEGACY_CHECKPOINT
        if not legacy.exists():
            return
        try:
            _, info = load_checkpoint(legacy)
            version = info["meta"]["version"]
            if isinstance(version, bool) or not isinstance(version, int) or version < 0:
                raise UnreadableFileError(legacy, f"holds no version number ({version!r})")
        except (ValueError, KeyError, TypeError) as exc:
            self.state.quarantine(legacy, reason_of(exc) if isinstance(exc, ValueError) else "holds no version number")
            return
        target = d / f"model-v{version}.pt"
        if target.exists():
            self.state.quarantine(legacy, f"an older layout's copy of version {version}, which {target.name} holds")
            return
        try:
            os.replace(legacy, target)
            fsync_directory(d)
        except OSError as exc:  # left as it is: the next start tries again
            log.warning("skill %s: could not rename %s to %s: %s", d.name, LEGACY_CHECKPOINT, target.name, exc)
            return
        log.info("skill %s: %s renamed %s (one checkpoint per version)", d.name, LEGACY_CHECKPOINT, target.name)

    def _load_version(self, d: Path, name: str, v: int, parts: dict[str, Path]) -> "SkillState":
        from acnmp_core.model.checkpoint import load_checkpoint

        ckpt = parts["model"]
        try:
            model, info = load_checkpoint(ckpt)
        except ValueError as exc:
            raise _Unusable(ckpt, reason_of(exc)) from None
        meta = info["meta"]
        if meta.get("version") != v or meta.get("skill", name) != name:
            raise _Unusable(ckpt, f"holds skill {meta.get('skill')!r} version {meta.get('version')!r}, its name says "
                                  f"{name} version {v}")
        state = SkillState(name, model, self._demos(d, meta.get("demos"), ckpt, info["data_hash"], "demonstrations"),
                           v, source_hash=meta.get("source_hash"), trained_as=meta.get("trained_as"))
        if meta.get("partner"):
            partner = self._part(d, meta.get("partner"), ckpt, "robot B's checkpoint")
            try:
                state.partner, partner_info = load_checkpoint(partner)
            except ValueError as exc:
                raise _Unusable(partner, reason_of(exc)) from None
            state.partner_demos = self._demos(d, meta.get("partner_demos"), partner, partner_info["data_hash"],
                                              "robot B's demonstrations")
        return state

    def _part(self, d: Path, file: object, ckpt: Path, what: str) -> Path:
        """The file ``file`` a checkpoint names for ``what``; :class:`_Unusable` (the checkpoint)
        when it names none, or one that is missing."""
        if not isinstance(file, str) or not file or Path(file).name != file or file in (".", ".."):
            raise _Unusable(ckpt, f"names no file for its {what} ({file!r})")
        if not (d / file).is_file():
            raise _Unusable(ckpt, f"names {file} ({what}), which is missing")
        return d / file

    def _demos(self, d: Path, file: object, ckpt: Path, data_hash: str, what: str) -> DemoSet:
        path = self._part(d, file, ckpt, what)
        try:
            demos = load_demos(path).to_demo_set()
        except ValueError as exc:
            raise _Unusable(path, reason_of(exc)) from None
        if demos.content_hash() != data_hash:
            raise _Unusable(path, f"does not match the data hash that {ckpt.name} records")
        return demos


def _versioned_files(d: Path) -> dict[int, dict[str, Path]]:
    """{version: {kind (model, demos, partner, partner-demos): path}} of the files in ``d``."""
    out: dict[int, dict[str, Path]] = {}
    for p in d.iterdir():
        m = _VERSIONED.match(p.name)
        if m and p.is_file():
            out.setdefault(int(m.group(2)), {})[m.group(1)] = p
    return out


#: Format version of a job's roll-out journal (:meth:`JobStore.save_journal`).
JOURNAL_VERSION = 1


class JobStore:
    """Job records under ``<state_dir>/jobs``, one JSON file each, written atomically and durably.

    ``state`` : a :class:`StateDir` or its path.
    """

    def __init__(self, state: "StateDir | str | os.PathLike"):
        self.state = state if isinstance(state, StateDir) else StateDir(state)
        self.root = self.state.root / "jobs"
        self.root.mkdir(parents=True, exist_ok=True)

    def path(self, job_id: str) -> Path:
        """The record file of job ``job_id``."""
        return self.root / f"{check_name('job', job_id)}.json"

    def save(self, job: JobRecord) -> None:
        """Write one job record (sets ``updated``); :class:`StateWriteError` when it cannot be
        written (the file on disk is then unchanged)."""
        job.updated = time.time()
        self.state.write(self.path(job.job), json.dumps(job.to_dict(), allow_nan=False).encode(), f"job {job.job}")

    def delete(self, job_id: str) -> None:
        """Remove the record of job ``job_id`` and its journal (OSError when they cannot be removed)."""
        self.path(job_id).unlink(missing_ok=True)
        self.journal_path(job_id).unlink(missing_ok=True)

    def journals(self) -> list[str]:
        """The jobs that have a roll-out journal, by id."""
        names = []
        for p in sorted(self.root.glob("*.rollouts")):
            try:
                names.append(check_name("job", p.name[:-len(".rollouts")]))
            except ValueError:
                self.state.quarantine(p, "not the journal of a job (its name is no job id)")
        return names

    def journal_path(self, job_id: str) -> Path:
        """The journal of job ``job_id``: its roll-out events the recorder has not confirmed (``<job>.rollouts``)."""
        return self.root / f"{check_name('job', job_id)}.rollouts"

    def save_journal(self, job_id: str, events: list[dict]) -> None:
        """Write the roll-out events (event maps, services/recording/events.py) job ``job_id`` is
        about to publish, replacing the journal's earlier ones; :class:`StateWriteError` when it
        cannot be written (the journal on disk is then unchanged)."""
        data = encode({"v": JOURNAL_VERSION, "events": events}, allow_non_finite=True)
        self.state.write(self.journal_path(job_id), data, f"the roll-out journal of job {job_id}")

    def take_journal(self, job_id: str) -> list[dict]:
        """The events of job ``job_id``'s journal ([] when it has none; a journal that cannot be
        read is quarantined, and [] returned). The journal stays until :meth:`drop_journal`."""
        path = self.journal_path(job_id)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            return []
        except OSError as exc:
            log.warning("job %s: cannot read its roll-out journal: %s", job_id, exc)
            return []
        try:
            msg = decode(data, expect_version=JOURNAL_VERSION, allow_non_finite=True)
            events = msg["events"]
            if not isinstance(events, list) or not all(isinstance(ev, dict) for ev in events):
                raise WireError("malformed", "events: expected a list of maps")
        except (WireError, KeyError) as exc:
            self.state.quarantine(path, f"not a roll-out journal ({exc})")
            return []
        return events

    def drop_journal(self, job_id: str) -> None:
        """Remove job ``job_id``'s journal (once its events are published again)."""
        try:
            self.journal_path(job_id).unlink(missing_ok=True)
        except OSError as exc:
            log.warning("job %s: cannot remove its roll-out journal: %s", job_id, exc)

    def load_all(self) -> dict[str, JobRecord]:
        """Every readable job record, by id, oldest first; temp files of dead writers removed, an
        unreadable record quarantined. Never raises for a bad file."""
        self.state.remove_stale_temps(self.root)
        jobs = []
        for p in sorted(self.root.glob("*.json")):
            try:
                data = json.loads(p.read_text())
            except (OSError, UnicodeDecodeError, ValueError):
                self.state.quarantine(p, "not a job record (truncated or not JSON)")
                continue
            try:
                job = JobRecord.from_dict(data)
            except RecordFormatError as exc:
                self.state.quarantine(p, str(exc))
                continue
            except Exception as exc:  # any field missing or of the wrong type
                self.state.quarantine(p, f"not a job record ({type(exc).__name__}: {exc})".splitlines()[0])
                continue
            if job.job != p.stem:
                self.state.quarantine(p, f"holds job {job.job!r}, its name says {p.stem!r}")
                continue
            jobs.append(job)
        return {j.job: j for j in sorted(jobs, key=lambda j: j.created)}
