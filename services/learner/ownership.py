"""Which learner of a deployment serves a skill, when a deployment runs several.

A deployment of K learners is started with the same list of learner ids on every learner
(``--learners ID,ID,...``, ``acnmp up --learners K``). Each skill belongs to exactly one of them,
chosen by rendezvous hashing of the skill's name over that list (:func:`owner_of`): every learner
computes the same owner without asking anyone, so two learners never both take a skill, and a
skill stays with its learner (and its state directory, where its checkpoints and job records
are) for the deployment's life. The learners keep the wildcard queryables a lone learner
declares; a request for a skill or one of its jobs reaches all of them through the router, and
only the skill's owner answers it (:class:`Ownership`); the others drop it unanswered while the
owner is live, and answer ``unavailable`` naming the owner while it is not (it died, or is cut
off): its skills and jobs are back when it restarts on its state directory, and nothing of them
runs anywhere else meanwhile.

Whether a learner is live is its liveliness token ``acnmp/<ns>/learner/<id>`` (watched by a
liveliness subscriber). The learner set is fixed for a deployment: a learner added or removed
moves skills to other owners, whose state directories do not hold them.
"""
from __future__ import annotations

import argparse
import hashlib
import threading
from pathlib import Path
from typing import Sequence

from services.transport.keys import check_name


def owner_of(skill: str, learners: Sequence[str]) -> str:
    """The learner id of ``learners`` that serves ``skill``: the highest SHA-256 of ``id/skill``
    (rendezvous hashing: removing one learner moves only its own skills). ValueError for an
    empty list."""
    if not learners:
        raise ValueError("learners: expected at least one learner id")
    return max(learners, key=lambda lid: hashlib.sha256(f"{lid}/{skill}".encode()).digest())


def numbered_ids(k: int) -> tuple[str, ...]:
    """The ids a launcher gives its ``k`` (>= 1) learners: ``learner``, ``learner-2``, ...
    ValueError for ``k`` < 1."""
    if k < 1:
        raise ValueError(f"learners: expected >= 1, got {k}")
    return tuple("learner" if i == 0 else f"learner-{i + 1}" for i in range(int(k)))


def state_dir_of(state_dir: Path, learners: Sequence[str], learner: str) -> Path:
    """Where learner ``learner`` of a launcher's ``learners`` keeps its state: the deployment's
    ``state_dir`` for the first, ``<state_dir>/learners/<id>`` for the others."""
    return state_dir if learner == learners[0] else state_dir / "learners" / learner


def learner_argv(learner: str, learners: Sequence[str], state_dir: Path) -> list[str]:
    """The learner options a launcher gives learner ``learner`` of ``learners``: its
    ``--state-dir`` (:func:`state_dir_of`) and ``--id``, and ``--learners`` when there are several."""
    argv = ["--state-dir", str(state_dir_of(state_dir, learners, learner)), "--id", learner]
    return argv + (["--learners", ",".join(learners)] if len(learners) > 1 else [])


def skill_of_job(job: str) -> str:
    """The skill of job id ``job`` (``<skill>-<10 hex>``)."""
    skill, sep, _ = job.rpartition("-")
    return skill if sep else job


def parse_learners(text: str) -> tuple[str, ...]:
    """``--learners ID,ID,...`` -> the ids (each a valid name, no repeats); ValueError naming the option."""
    ids = tuple(part.strip() for part in text.split(",") if part.strip())
    try:
        for lid in ids:
            check_name("learner id", lid)
    except ValueError as exc:
        raise ValueError(f"--learners: {exc}") from None
    if len(set(ids)) != len(ids):
        raise ValueError(f"--learners: an id is given twice in {text!r}")
    if not ids:
        raise ValueError("--learners: expected one or more learner ids, comma-separated")
    return ids


def learner_ids(text: str) -> tuple[str, ...]:
    """The argparse type of ``--learners``: :func:`parse_learners`, its error as argparse's."""
    try:
        return parse_learners(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--learners: ")) from None


class Ownership:
    """What this learner (``me``) answers among ``learners``.

    :meth:`decide` tells a handler, for a skill's request, ``"serve"`` (this learner owns it),
    ``"drop"`` (the owner is live: it answers) or the owner's id when the owner is not live (the
    handler answers ``unavailable`` naming it). ``live`` is updated by :meth:`token_changed`
    (from a liveliness subscriber on ``acnmp/<ns>/learner/*``). A lone learner (``learners``
    empty or just ``me``) serves everything.
    """

    def __init__(self, me: str, learners: Sequence[str] = ()):
        self.me = me
        self.learners = tuple(learners)
        if self.learners and me not in self.learners:
            raise ValueError(f"--learners: this learner's id {me!r} is not among {list(self.learners)}")
        self._live: set[str] = {me}
        self._lock = threading.Lock()

    @property
    def alone(self) -> bool:
        """True when this learner serves every skill."""
        return len(self.learners) <= 1

    def owner(self, skill: str) -> str:
        """The id of the learner that serves ``skill``."""
        return self.me if self.alone else owner_of(skill, self.learners)

    def token_changed(self, learner: str, alive: bool) -> None:
        """Learner ``learner``'s token appeared (``alive``) or went."""
        with self._lock:
            if alive:
                self._live.add(learner)
            elif learner != self.me:
                self._live.discard(learner)

    def live(self) -> list[str]:
        """The ids of the learners whose tokens this learner sees live (itself among them), sorted."""
        with self._lock:
            return sorted(self._live)

    def decide(self, skill: str) -> str:
        """``"serve"``, ``"drop"``, or the id of the owner that is not live (see the class)."""
        owner = self.owner(skill)
        if owner == self.me:
            return "serve"
        with self._lock:
            return "drop" if owner in self._live else owner
