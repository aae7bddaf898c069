"""The learner's durable state: skills (model + demonstrations) and adaptation jobs, under one directory.

Layout of ``<state_dir>``::

    skills/<skill>/demos-v<version>.npz   the DemoSet (acnmp_core.demo_io format, padded + lengths)
    skills/<skill>/model.pt               acnmp_core.checkpoint; meta: version, demos file, n_demos,
                                          source_hash (of the demonstrations it was trained from),
                                          trained_as (of the training that made this version)
    skills/<skill>/partner-v<version>.pt  a paired skill's robot B model (meta of model.pt names it)
    skills/<skill>/partner-demos-v<version>.npz   and robot B's demonstrations
    jobs/<job>.json                       one job record (JSON)

Every file is written atomically (temp file in the same directory + ``os.replace``), so a
``kill -9`` at any moment leaves either the old or the new version. A skill's commit point is its
checkpoint: the demonstrations of a new version are written first under a new name, then the
checkpoint naming them replaces the old one, then older demo files are removed. On load, the
demonstrations' content hash is checked against the hash stored in the checkpoint.

Job records (services/learner/jobs.py) are JSON (arrays as nested lists). Roll-out indices are
reserved in the record (``next_index``) *before* the roll-outs' events are published, so a crash can
leave a gap in the indices but never reuse one.
"""
from __future__ import annotations

import fcntl
import json
import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from acnmp_core.checkpoint import load_checkpoint, save_checkpoint
from acnmp_core.cnmp import CNMP
from acnmp_core.data import DemoSet
from acnmp_core.demo_io import DemoArrays, load_demos, save_demos
from services.transport.keys import check_name

from .jobs import JobRecord


class StateDirInUse(RuntimeError):
    """Another live process holds the lock of a state directory (see :class:`DirectoryLock`)."""


class DirectoryLock:
    """An exclusive lock on a directory for as long as this process holds it.

    ``flock`` on ``<directory>/<name>`` (created, mode 0600): the OS releases it when the holder
    exits, even by ``kill -9``, so a stale lock never needs cleaning up. The file holds the
    holder's pid and ``owner``, quoted when another process is refused. Re-entrant within one
    object only: a second lock on the same file, even in this process, is refused.
    """

    def __init__(self, directory: str | os.PathLike, name: str, owner: str):
        self.path = Path(directory).resolve() / name
        self.owner = owner
        self._fd: int | None = None

    def acquire(self) -> "DirectoryLock":
        """Take the lock or raise :class:`StateDirInUse` naming the directory and the holder."""
        if self._fd is not None:
            return self
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 200).decode("utf-8", "replace").strip() or "unknown"
            os.close(fd)
            raise StateDirInUse(f"state directory {self.path.parent} is in use by another {self.owner} "
                                f"(pid {holder}); stop it first or give another --state-dir") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()} ({self.owner})\n".encode())
        self._fd = fd
        return self

    def release(self) -> None:
        """Give the lock up (the file stays: removing it would race with a newcomer)."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> "DirectoryLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temp file in the same directory and ``os.replace``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


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

    A **paired skill** (a :class:`~acnmp_core.transfer.TransferPair` trained by a ``train_pair``
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


class SkillStore:
    """Saves and loads skills under ``<state_dir>/skills``."""

    def __init__(self, state_dir: str | os.PathLike):
        self.root = Path(state_dir) / "skills"
        self.root.mkdir(parents=True, exist_ok=True)

    def save(self, skill: SkillState) -> None:
        """Write demonstrations, then the checkpoint (the commit point), then drop older demo files."""
        d = self.root / check_name("skill", skill.name)
        demo_file = f"demos-v{skill.version}.npz"
        save_demos(d / demo_file, demo_set_to_arrays(skill.demos, skill.model.config.output_names,
                                                     skill.model.config.task_param_names))
        meta = {"skill": skill.name, "version": int(skill.version), "demos": demo_file, "n_demos": len(skill.demos)}
        if skill.source_hash is not None:
            meta["source_hash"] = skill.source_hash
        if skill.trained_as is not None:
            meta["trained_as"] = skill.trained_as
        keep = {demo_file}
        if skill.partner is not None:  # files of this version only: the old checkpoint still names the old ones
            partner_file, partner_demos = f"partner-v{skill.version}.pt", f"partner-demos-v{skill.version}.npz"
            save_demos(d / partner_demos, demo_set_to_arrays(skill.partner_demos, skill.partner.config.output_names))
            save_checkpoint(skill.partner, d / partner_file, data_hash=skill.partner_demos.content_hash())
            meta.update(partner=partner_file, partner_demos=partner_demos)
            keep |= {partner_file, partner_demos}
        save_checkpoint(skill.model, d / "model.pt", data_hash=skill.demos.content_hash(), meta=meta)
        for pattern in ("demos-v*.npz", "partner-v*.pt", "partner-demos-v*.npz"):
            for old in d.glob(pattern):
                if old.name not in keep:
                    old.unlink(missing_ok=True)

    def load_all(self) -> dict[str, SkillState]:
        """Every saved skill, by name. Raises ValueError if a skill's demos do not match its hash."""
        out = {}
        for d in sorted(p for p in self.root.iterdir() if (p / "model.pt").is_file()):
            model, info = load_checkpoint(d / "model.pt")
            meta = info["meta"]
            demos = load_demos(d / meta["demos"]).to_demo_set()
            if demos.content_hash() != info["data_hash"]:
                raise ValueError(f"skill {d.name}: demonstrations do not match the checkpoint's data hash")
            state = SkillState(d.name, model, demos, int(meta["version"]), source_hash=meta.get("source_hash"),
                               trained_as=meta.get("trained_as"))
            if meta.get("partner"):
                state.partner, partner_info = load_checkpoint(d / meta["partner"])
                state.partner_demos = load_demos(d / meta["partner_demos"]).to_demo_set()
                if state.partner_demos.content_hash() != partner_info["data_hash"]:
                    raise ValueError(f"skill {d.name}: robot B's demonstrations do not match their checkpoint's hash")
            out[d.name] = state
        return out


class JobStore:
    """Job records under ``<state_dir>/jobs``, one JSON file each, written atomically."""

    def __init__(self, state_dir: str | os.PathLike):
        self.root = Path(state_dir) / "jobs"
        self.root.mkdir(parents=True, exist_ok=True)

    def save(self, job: JobRecord) -> None:
        """Write one job record (sets ``updated``)."""
        job.updated = time.time()
        atomic_write_bytes(self.root / f"{check_name('job', job.job)}.json",
                           json.dumps(job.to_dict(), allow_nan=False).encode())

    def load_all(self) -> dict[str, JobRecord]:
        """Every job record, by id, oldest first."""
        jobs = [JobRecord.from_dict(json.loads(p.read_text())) for p in self.root.glob("*.json")]
        return {j.job: j for j in sorted(jobs, key=lambda j: j.created)}
