"""A job as the learner keeps it: the request, where it stands, and its result.

A job is an adaptation (request :class:`~acnmp_core.jobs.adapt.AdaptJob`, result
:class:`~acnmp_core.adaptation.config.AdaptResult`) or a paired skill's training (``kind``
``train_pair``: :class:`~acnmp_core.jobs.transfer.PairTrainJob`, :class:`~acnmp_core.jobs.transfer.PairJobResult`);
a record without ``kind`` is an adaptation, so the records of earlier versions load.

One :class:`JobRecord` per job lives in the learner's memory and, as JSON, in
``<state_dir>/jobs/<job>.json`` (services/learner/store.py). Request and result are typed; only
:meth:`JobRecord.to_dict` and :meth:`JobRecord.from_dict` turn them into plain values and back.
The JSON layout is the one the learner has always written, plus ``kind`` and ``format``.
"""
from __future__ import annotations

import time
import uuid
from dataclasses import dataclass, field
from typing import Any

from acnmp_core.adaptation.config import AdaptResult
from acnmp_core.jobs.adapt import AdaptJob, result_from_dict, result_to_dict
from acnmp_core.jobs.transfer import PairJobResult, PairTrainJob
from services.transport.wire import jsonable
from services.worker.exclusion import Exclusion

#: Job states: queued -> running -> done | failed | cancelled. ``interrupted``: the learner stopped
#: (SIGTERM) while the job ran; a ``running`` record found at start-up means the learner died
#: (kill -9). Both resume on the next start under a new attempt number.
JOB_STATES = ("queued", "running", "interrupted", "done", "failed", "cancelled")
UNFINISHED = ("queued", "running", "interrupted")
#: States a job never leaves.
TERMINAL = ("done", "failed", "cancelled")
#: Format of a job record's JSON (its ``format`` field; a record without one is of format 1).
RECORD_FORMAT = 1


class RecordFormatError(ValueError):
    """A job record of a format this learner does not read."""


@dataclass
class JobRecord:
    """One job.

    job : id ``<skill>-<10 hex>``. skill : the skill it adapts. request : what was asked.
    state : one of :data:`JOB_STATES`. attempt : 0, +1 per restart after an interruption.
    next_index : next free roll-out index (indices are global over attempts; reserved before the
        events naming them are published). attempt_start_index : first index of this attempt.
    iteration, rollouts : of the current attempt. best_return : best return seen, or None.
    result : the adaptation's outcome once it finished. error : why it failed.
    cancel_requested : a ``cancel`` query arrived while the job ran; it stops at its next
        iteration (also after a restart) and ends ``cancelled``.
    committed_version : the skill version holding the assimilated solution.
    excluded_workers : the workers excluded from the job, each with why and in which attempt
        (services/worker/exclusion.py), in the order they were; the status shows the current
        attempt's (:meth:`exclusions`).
    created, updated : wall time (s since the epoch).
    """

    job: str
    skill: str
    request: AdaptJob | PairTrainJob
    state: str = "queued"
    attempt: int = 0
    next_index: int = 0
    attempt_start_index: int = 0
    iteration: int = 0
    rollouts: int = 0
    best_return: float | None = None
    result: AdaptResult | PairJobResult | None = None
    error: str | None = None
    committed_version: int | None = None
    cancel_requested: bool = False
    excluded_workers: tuple[Exclusion, ...] = ()
    created: float = field(default_factory=time.time)
    updated: float = 0.0

    @classmethod
    def new(cls, skill: str, request: AdaptJob | PairTrainJob) -> "JobRecord":
        """A fresh, queued job for ``request`` on ``skill`` with a new id."""
        return cls(f"{skill}-{uuid.uuid4().hex[:10]}", skill, request)

    def to_dict(self) -> dict[str, Any]:
        """The JSON-ready map written to the job's file."""
        out = {k: getattr(self, k) for k in self.__dataclass_fields__}
        out["format"] = RECORD_FORMAT
        out["kind"] = self.kind
        out["request"] = self.request.to_dict()
        out["result"] = self._result_dict()
        out["excluded_workers"] = [e.to_dict() for e in self.excluded_workers]
        return jsonable(out)

    @property
    def kind(self) -> str:
        """``adapt`` (an adaptation) or ``train_pair`` (a paired skill's training), from the request's type."""
        return "train_pair" if isinstance(self.request, PairTrainJob) else "adapt"

    def _result_dict(self) -> dict[str, Any] | None:
        if self.result is None:
            return None
        return self.result.to_dict() if isinstance(self.result, PairJobResult) else result_to_dict(self.result)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "JobRecord":
        """Inverse of :meth:`to_dict`; :class:`RecordFormatError` for a record of another format,
        KeyError/TypeError/ValueError for one that is not a job record."""
        if d.get("format", RECORD_FORMAT) != RECORD_FORMAT:
            raise RecordFormatError(f"a job record of format {d.get('format')!r}; this learner reads format {RECORD_FORMAT}")
        values = {k: d[k] for k in cls.__dataclass_fields__ if k in d}
        if d.get("kind", "adapt") == "train_pair":  # records written before kinds existed are adapt jobs
            values["request"] = PairTrainJob.from_dict(d["request"])
            values["result"] = None if d.get("result") is None else PairJobResult.from_dict(d["result"])
        else:
            values["request"] = AdaptJob.from_dict(d["request"])
            values["result"] = None if d.get("result") is None else result_from_dict(d["result"])
        values["excluded_workers"] = tuple(Exclusion.from_dict(e) for e in d.get("excluded_workers") or ())
        if not isinstance(values.get("job"), str) or not isinstance(values.get("skill"), str):
            raise ValueError("fields 'job' and 'skill': expected strings")
        if values.get("state", "queued") not in JOB_STATES:
            raise ValueError(f"field 'state': {values.get('state')!r} is not one of {list(JOB_STATES)}")
        return cls(**values)

    def exclusions(self) -> tuple[Exclusion, ...]:
        """The workers excluded by the current (or final) attempt: an earlier attempt's ended with
        its learner (a kill -9 of a launcher takes its workers down with it), so they are not this
        attempt's; the record keeps them all."""
        return tuple(e for e in self.excluded_workers if e.attempt == self.attempt)

    def summary(self) -> dict[str, Any]:
        """One row of the job list (docs/PROTOCOL.md, ``jobs``): the status without the result's
        arrays, with whether it succeeded and the wall times."""
        status = self.status()
        result = status.pop("result")
        status.update(success=None if result is None else bool(result.get("success", False)),
                      created=self.created, updated=self.updated)
        return status

    def status(self) -> dict[str, Any]:
        """The job status reply (docs/PROTOCOL.md, ``job/<job>/status``)."""
        req = self.request
        status = {"v": 1, "job": self.job, "kind": self.kind, "skill": self.skill, "state": self.state,
                  "attempt": self.attempt, "iteration": self.iteration, "rollouts": self.rollouts,
                  "rollouts_executed": self.next_index, "best_return": self.best_return, "error": self.error,
                  "committed_version": self.committed_version, "cancel_requested": self.cancel_requested,
                  "excluded_workers": [e.to_dict() for e in self.exclusions()], "result": self._result_dict()}
        if isinstance(req, PairTrainJob):  # iteration counts training steps, of steps
            status.update(task="train_pair", robot=req.robot_b, commit=True, steps=req.config.steps,
                          budget=req.config.steps)
        else:
            status.update(task=req.task, robot=req.robot, commit=req.commit, budget=req.config.max_rollouts)
        return status
