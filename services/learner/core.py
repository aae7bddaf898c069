"""The learner without zenoh: skills (CNMP + demonstrations + version), training, adaptation and
paired-skill jobs.

:class:`LearnerCore` owns the durable state (services/learner/store.py) and runs up to ``jobs``
jobs at once, each on a job thread of its own with a runner of its own (services/learner/runner.py:
the adaptation's arithmetic on that thread, or in a child process, so jobs do not take turns on
the GIL): :func:`acnmp_core.adaptation.loop.adapt` on a copy of the skill's model, with the
evaluator its ``evaluator_for`` callable builds for the job (the service passes a
:class:`~services.worker.remote.RemoteEvaluator` over the workers; a test may pass the in-process
task). With ``commit`` a successful solution is assimilated: added to the demonstrations, the model
trains on (``fit_normalization=False``) and a new version is committed. Everything the outside
sees goes through two callables: ``publish(event)`` for events (services/recording/events.py) and
``on_version(state)`` when a skill version is committed (the service puts the weights).

A ``train_pair`` job (:class:`~acnmp_core.jobs.transfer.PairTrainJob`) runs on the same queue:
:func:`acnmp_core.transfer.pair.train_pair` on a fresh pair, progress every 5 % of its steps, and the
pair committed as the skill's next version (robot A's CNMP as its model, robot B's as its
``partner``), with the latents of both robots' demonstrations published.

Restart: skills reload with their demonstrations (hash-checked); a job that was running restarts
**from its beginning with the same seed** under a new ``attempt`` number (adapt() cannot be resumed
mid-way). Roll-out indices stay global over attempts: an attempt's events continue after the
indices the earlier attempts reserved, so a recording never holds one index twice. A batch's
roll-out events are written to the job's journal (beside those the recorder has not confirmed
yet) before their indices are reserved, and published after; a roll-out leaves the journal once
the recorder says its file holds it, and a start publishes every journal again, one by one,
before any job runs (services/learner/journals.py: one that cannot be published is quarantined,
one whose publishing fails is kept and tried again, and neither holds up the others), so a kill
-9 anywhere, of the recorder too, costs the recording no roll-out (the recorder drops the ones it
holds by job and index). A finished job's journal goes once the recorder holds its roll-outs. Every event of
a job carries ``attempt``; the job status reports ``rollouts`` (what the final attempt used) and
``rollouts_executed`` (all attempts). A job whose adaptation had finished but whose assimilation
had not is only re-assimilated (once).

Stopping and cancelling: :meth:`LearnerCore.close` (SIGTERM) interrupts the running job at once
(the evaluator sees :attr:`LearnerCore.stopping`; the iteration in flight is dropped, since the
next attempt starts over) and saves it as ``interrupted``. :meth:`LearnerCore.cancel` ends a
queued job at once and a running one after the iteration in flight (its roll-outs are recorded),
saved as ``cancelled``.

Memory follows the disk: every change to a job is written first (:meth:`LearnerCore._persist`
writes a changed copy) and made in memory only once the write returned, so a job is accepted,
and a cancel answered, only once its record is durable, and what a status reply says is what a
restart finds; a failed write (:class:`~services.learner.store.StateWriteError`) refuses the
request and changes nothing. A write that fails while a job runs fails that job with the write's
message; its ``failed`` record is written as soon as the disk takes it (retried meanwhile; the
job loop goes on with the next job only then), and :meth:`LearnerCore.health` reports the
failure until a write succeeds. Bounds (:class:`~services.learner.limits.StateLimits`): at most
``max_queued_jobs`` unfinished jobs (:class:`LearnerBusy` beyond), finished records pruned by
count and age, ``keep_versions`` checkpoints per skill. Jobs are picked in the order they were
queued by the job threads (:meth:`LearnerCore._next_job`), each marking the one it runs as active.
A job's result does not depend on the jobs beside it: each has its own copy of the model, its own
optimiser and random streams (from its seed), and its own roll-outs; the workers serve the
batches of concurrent jobs in the order they arrive, so every job advances. Trainings and
assimilations (which change a skill) still run one at a time.
"""
from __future__ import annotations

import contextlib
import copy
import dataclasses
import hashlib
import json
import logging
import os
import threading
import time
from dataclasses import asdict, dataclass
from typing import Callable

import numpy as np
import torch

from acnmp_core.adaptation.loop import adapt
from acnmp_core.adaptation.assimilation import AssimilationConfig, assimilate
from acnmp_core.adaptation.config import AdaptTarget, IterationLog
from acnmp_core.data.demos import DemoSet, Demonstration
from acnmp_core.jobs.adapt import AdaptJob
from acnmp_core.jobs.transfer import PairJobResult, PairTrainJob
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.training import TrainConfig, train
from acnmp_core.rollout import RolloutBatch, RolloutEvaluator
from acnmp_core.transfer.pair import PairTrainResult, TransferPair, latent_plane, train_pair
from services.recording.event_ids import IndexRanges
from services.recording.events import (batch_rollout_events, job_event, job_progress_event, latent_event,
                                       model_version_event, robot_drawing)
from services.transport.state_dir import DirectoryLock

from .jobs import TERMINAL, UNFINISHED, JobRecord
from .journals import RETRY_S as JOURNAL_RETRY_S, Journals, PendingJournal, Settled
from .limits import StateLimits, busy_message
from .runner import AdaptRunner, AdaptTask, make_runner
from .metrics import MetricsReporter
from .store import JobStore, Quarantined, SkillState, SkillStore, StateDir, StateWriteError

log = logging.getLogger(__name__)


class UnknownSkillError(ValueError):
    """No skill of that name on this learner (answered ``unknown_skill``)."""


class UnknownJobError(ValueError):
    """No job of that id on this learner (answered ``unknown_job``)."""


class JobCancelled(Exception):
    """Raised inside a job's adaptation once its cancellation was asked for."""


class LearnerBusy(RuntimeError):
    """The learner holds as many unfinished jobs as its limit allows (answered ``busy``)."""


#: Seconds between tries to write a finished job's record while the disk refuses it (doubling).
RETRY_FIRST, RETRY_MAX = 0.5, 5.0
#: Quarantined files a health report names one by one (the rest are counted).
HEALTH_FILES = 10


@dataclass(frozen=True)
class LearnerHealth:
    """What the learner reports about itself (``acnmp status``).

    loop_running : the job loop runs (False before :meth:`LearnerCore.start` and after close).
    loop_error : why the job loop ended, if it ended by an error.
    write_error : the last state write's failure, None once a write succeeded again.
    quarantined : every file under the state directory's quarantine.
    pending_journals : journalled roll-outs whose publishing failed (tried again until it works).
    notes : one line per skill not served at its newest version since the start (why, and which is).
    """

    loop_running: bool
    loop_error: str | None
    write_error: str | None
    quarantined: tuple[Quarantined, ...]
    pending_journals: tuple[PendingJournal, ...] = ()
    notes: tuple[str, ...] = ()

    def problems(self) -> list[str]:
        """One line per problem (empty when healthy)."""
        out = []
        if self.loop_error is not None:
            out.append(f"the job loop has stopped: {self.loop_error}")
        if self.write_error is not None:
            out.append(f"cannot write its state: {self.write_error}")
        out += list(self.notes) + [p.line() for p in self.pending_journals]
        out += [q.line() for q in self.quarantined[:HEALTH_FILES]]
        if len(self.quarantined) > HEALTH_FILES:
            out.append(f"... and {len(self.quarantined) - HEALTH_FILES} more quarantined files")
        return out


@dataclass(frozen=True)
class TrainSpec:
    """A validated train request: demonstrations, model and training settings, seed."""

    demos: DemoSet
    model_cfg: CNMPConfig
    train_cfg: TrainConfig
    seed: int = 0


def train_fingerprint(spec: TrainSpec) -> str:
    """SHA-256 of what decides the weights a train request gives: the demonstrations' content
    hash, the architecture (not the names of its inputs and outputs), every training setting and
    the seed. Two requests with the same fingerprint train the same model."""
    cfg = spec.model_cfg
    what = {"demos": spec.demos.content_hash(), "seed": int(spec.seed), "train": asdict(spec.train_cfg),
            "model": [cfg.n_outputs, cfg.n_task_params, list(cfg.encoder_widths), list(cfg.decoder_widths),
                      float(cfg.std_floor)]}
    return hashlib.sha256(json.dumps(what, sort_keys=True).encode()).hexdigest()


def pair_latent_events(state: SkillState, robots: tuple[str | None, str | None]) -> list[dict]:
    """``latent`` events of a paired skill's version: robot A's demonstration i through A's
    encoder (label ``a-demo<i>``) and robot B's through B's (``b-demo<i>``), ``robot`` the kinds
    when known, each with ``map_xy``, its place on the principal plane of all 2 N latents."""
    latents, labels, kinds = [], [], []
    for side, model, demos, kind in (("a", state.model, state.demos, robots[0]),
                                     ("b", state.partner, state.partner_demos, robots[1])):
        for i, demo in enumerate(demos):
            latents.append(model.encode_demo(demo.times, demo.values))
            labels.append(f"{side}-demo{i}")
            kinds.append(kind or f"robot_{side}")
    plane = latent_plane(np.stack(latents))
    return [latent_event(state.name, state.version, z, label=label, robot=kind, map_xy=xy)
            for z, label, kind, xy in zip(latents, labels, kinds, plane)]


class LearnerCore:
    """Skills and jobs of one learner; :meth:`start` runs queued jobs, :meth:`close` stops.

    Parameters
    ----------
    state_dir : where skills and jobs are checkpointed; locked while this core lives
        (:class:`~services.learner.store.StateDirInUse` if another learner holds it). Unusable
        files in it are quarantined at start (services/learner/store.py), never fatal.
    evaluator_for : ``job -> RolloutEvaluator`` that executes the job's roll-outs.
    publish : ``event -> None``; every event the learner emits (versions, latents, roll-outs, progress).
    on_version : ``SkillState -> None``; called after a new version is checkpointed, before its events.
    device : where the skills' networks train, adapt and assimilate (``cpu``, ``cuda``, ``auto``;
        acnmp_core/model/device.py): a skill loaded from the state directory or newly trained is moved
        there once; its checkpoints load on any device.
    state_limits : queue limit, job records and checkpoints kept (services/learner/limits.py).
    jobs : how many jobs run at once (job threads).
    job_runner : where an adaptation computes, ``thread`` (the job thread) or ``process`` (a child
        process per job thread, started by :meth:`start`); services/learner/runner.py.
    """

    def __init__(self, state_dir: str | os.PathLike, *, evaluator_for: Callable[[AdaptJob], RolloutEvaluator],
                 publish: Callable[[dict], None] = lambda _event: None,
                 on_version: Callable[[SkillState], None] = lambda _state: None, device: str = "cpu",
                 state_limits: StateLimits = StateLimits(), jobs: int = 1, job_runner: str = "thread"):
        from acnmp_core.model.device import resolve_device

        self.device = resolve_device(device)  # before anything is locked: a bad device changes nothing
        if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
            raise ValueError(f"jobs: expected an integer >= 1, got {jobs!r}")
        self._runners = [make_runner(job_runner, f"job-{i}") for i in range(jobs)]
        # one learner per state directory: a second one would restart the first one's jobs
        self._dir_lock = DirectoryLock(state_dir, "learner.lock", "learner").acquire()
        self.limits = state_limits
        self.evaluator_for, self.publish, self.on_version = evaluator_for, publish, on_version
        self.metrics = MetricsReporter(publish)
        self._lock = threading.RLock()  # guards skills and jobs
        self._wake = threading.Condition(self._lock)  # a job was queued, or one ended
        self._train_lock = threading.Lock()  # one training at a time (the machine has few cores)
        try:
            self.state = StateDir(state_dir)
            self.state.remove_stale_temps(self.state.root)  # e.g. of the default skill's demonstrations
            self.skill_store = SkillStore(self.state, keep_versions=state_limits.keep_versions)
            self.job_store = JobStore(self.state)
            self.skills: dict[str, SkillState] = self.skill_store.load_all()
            for state in self.skills.values():
                for model in (state.model, state.partner):
                    if model is not None:
                        model.to_device(self.device)
            self.jobs: dict[str, JobRecord] = self.job_store.load_all()
        except BaseException:
            self._dir_lock.release()
            raise
        for job in self.jobs.values():  # a version a job record names is never given again
            for version in (job.committed_version, getattr(job.result, "version", None)):
                if isinstance(version, int):
                    self.skill_store.note_version(job.skill, version, f"job {job.job}")
        self.skill_store.note_missing(self.skills)  # a newest version deleted by hand is said aloud
        self._active: set[str] = set()  # jobs a loop thread runs
        self._stop = threading.Event()
        self._started = False
        self._loop_error: str | None = None
        for job in self.jobs.values():
            if job.state not in UNFINISHED:
                continue
            try:  # best effort: a job whose record cannot be written now is still run (see _run_job)
                if job.cancel_requested:  # cancelled, but the learner stopped before the job saw it
                    self._persist(job, state="cancelled")
                elif job.state in ("running", "interrupted"):  # restart under a new attempt number
                    self._persist(job, attempt=job.attempt + 1, state="queued")
            except StateWriteError as exc:
                log.warning("job %s: %s; it is resumed all the same", job.job, exc)
        self.journals = Journals(self.job_store, lambda event: self.publish(event), self._stop)
        self._read_journals()
        self._prune_jobs()
        self._replayed = threading.Event()  # the journals' events are published again: jobs may run
        self._replayer = threading.Thread(target=self._replay_journals, name="journals", daemon=True)
        self._threads = [threading.Thread(target=self._job_loop, args=(runner,), name=f"jobs-{i}", daemon=True)
                         for i, runner in enumerate(self._runners)]

    def _read_journals(self) -> None:
        """Read every job journal (services/learner/journals.py) for the replay; the indices they
        hold count as reserved: a job's ``next_index`` moves past them (the kill may have come
        between the journal's write and the reservation's)."""
        for job_id, top in self.journals.read().items():
            job = self.jobs.get(job_id)
            if job is not None and job.next_index < top:
                try:
                    self._persist(job, next_index=top)
                except StateWriteError as exc:
                    log.warning("job %s: %s; its journal's indices stay reserved in memory", job_id, exc)
                    job.next_index = top

    def _replay_journals(self) -> None:
        """Publish the journals' events again, one journal at a time, then let the jobs run; then
        try the held ones again until they are published (services/learner/journals.py): a
        roll-out whose indices were reserved reaches the recording even when the learner died
        before (or while) publishing it; the recorder keeps a learner job's roll-out once
        (services/recording/recorder.py)."""
        try:
            self.journals.replay()
        finally:
            self._replayed.set()
        while self.journals.pending() and not self._stop.wait(JOURNAL_RETRY_S):
            self.journals.retry()

    def settle_journals(self, held: Callable[[list[str]], dict[str, IndexRanges]]) -> Settled:
        """Drop from the jobs' journals the roll-outs the recorder holds (``held`` gets the ids of
        the jobs with journalled roll-outs and returns, per job, the indices the recording's files
        hold), and remove the journals of finished jobs left with none
        (:meth:`services.learner.journals.Journals.settle`)."""
        with self._lock:
            finished = [j.job for j in self.jobs.values() if j.state in TERMINAL]
        return self.journals.settle(finished, held)

    @property
    def stopping(self) -> threading.Event:
        """Set once :meth:`close` was called: an evaluator may watch it to abandon a batch in flight."""
        return self._stop

    def start(self) -> "LearnerCore":
        """Start running queued jobs (on a background thread); returns self."""
        self._started = True
        self._replayer.start()
        for thread in self._threads:
            thread.start()
        return self

    @property
    def jobs_at_once(self) -> int:
        """How many jobs this core runs at once."""
        return len(self._threads)

    @property
    def loop_error(self) -> str | None:
        """Why the job loop ended, if it ended while it should run (None: it runs, or was stopped)."""
        if self._loop_error is None and self._started and not all(t.is_alive() for t in self._threads) \
                and not self._stop.is_set():
            return "it ended without an error"
        return self._loop_error

    def health(self) -> LearnerHealth:
        """The learner's health now: its job loop, its last write, the quarantined files."""
        return LearnerHealth(all(t.is_alive() for t in self._threads), self.loop_error, self.state.write_error,
                             tuple(self.state.quarantined()), self.journals.pending(), tuple(self.skill_store.notes))

    # ----- skills ----------------------------------------------------------------------------
    def skill(self, name: str) -> SkillState:
        """The current state of skill ``name``; :class:`UnknownSkillError` if there is none."""
        with self._lock:
            state = self.skills.get(name)
        if state is None:
            raise UnknownSkillError(f"no skill {name!r}; train it first")
        return state

    def skill_states(self) -> dict[str, SkillState]:
        """A snapshot of every skill's current state, by name (committed states are never mutated)."""
        with self._lock:
            return dict(self.skills)

    def train_skill(self, skill: str, spec: TrainSpec) -> SkillState:
        """Train a new model for ``skill`` on ``spec``, checkpoint and commit it as the next version
        (one above every version of it ever committed). InterruptedError (nothing committed) once
        :meth:`interrupt` or :meth:`close` was called; :class:`StateWriteError` (nothing
        committed) when the checkpoint cannot be written."""
        model = CNMP(spec.model_cfg, seed=spec.seed)
        with self._train_lock:
            res = train(model, spec.demos, spec.train_cfg, seed=spec.seed, progress=False, stop=self._stop,
                        on_validation=self._train_curve(skill, spec.train_cfg.steps), device=self.device)
        choice = model.config.prior_choice
        # which model the demonstrations chose, and why, in one line (the recording's version event, the log)
        chosen = choice.reason if choice is not None else f"{model.config.prior} (as the request set it)"
        log.info("skill %s: model %s", skill, chosen)
        with self._lock:
            state = SkillState(skill, model, spec.demos, self.skill_store.next_version(skill),
                               source_hash=spec.demos.content_hash(), trained_as=train_fingerprint(spec))
            self._commit_skill(state, loss=res.best_val, note="trained", model=chosen)
        return state

    def trained_from(self, skill: str, spec: TrainSpec) -> SkillState | None:
        """``skill``'s current state if that version is what training on ``spec`` gives (trained
        from the same demonstrations, architecture, settings and seed, not assimilated since), else
        None: a train request that may reuse it (``reuse``) is answered with it without training."""
        with self._lock:
            state = self.skills.get(skill)
        if state is None or state.trained_as is None or state.trained_as != train_fingerprint(spec):
            return None
        return state

    def _train_curve(self, skill: str, steps: int) -> Callable[[int, float, float], None]:
        """``on_validation`` of ``skill``'s training: its loss curve to the recording and stderr."""
        def on_validation(step: int, nll: float, val: float) -> None:
            self.metrics.report(skill, "train", step, {"nll": nll, "val_nll": val},
                                f"skill {skill}: training step {step}/{steps}, nll {nll:.4f}, validation {val:.4f}",
                                last=step == steps)
        return on_validation

    def _commit_skill(self, state: SkillState, robots: tuple[str | None, str | None] = (None, None),
                      **extra) -> None:
        # checkpoint first (a published version must survive a crash), then announce it; a failed
        # checkpoint (StateWriteError) changes nothing
        self.skill_store.save(state)
        self.skills[state.name] = state
        self.on_version(state)
        self.publish(model_version_event(state.name, state.version, n_demos=len(state.demos),
                                         **{k: v for k, v in extra.items() if v is not None}))
        # The latent of every demonstration under this version, for the recording's latent view;
        # a paired skill's both robots', labelled a-/b-demo<i>, so paired latents sit side by side.
        if state.partner is None:
            for i, demo in enumerate(state.demos):
                latent = state.model.encode_demo(demo.times, demo.values, demo.task_params)
                self.publish(latent_event(state.name, state.version, latent, label=f"demo{i}"))
        else:
            for ev in pair_latent_events(state, robots):
                self.publish(ev)
        log.info("skill %s: version %d (%d demos)", state.name, state.version, len(state.demos))

    # ----- jobs ------------------------------------------------------------------------------
    def submit(self, skill: str, request: AdaptJob) -> JobRecord:
        """Queue ``request`` on ``skill``; returns the new job's record.

        Raises :class:`UnknownSkillError`, or the typed ValueError of a target that does not fit
        the skill's model (wrong output dimension, task parameters, time range);
        :class:`LearnerBusy` (before any check: a flood costs nothing) or
        :class:`StateWriteError` as :meth:`_enqueue`.
        """
        self._check_room()
        model = self.skill(skill).model
        request.target.query(model)  # the target must fit this skill's model
        return self._enqueue(skill, request)

    def submit_pair(self, skill: str, request: PairTrainJob) -> JobRecord:
        """Queue the training of paired skill ``skill`` (a new skill, or the next version of one);
        returns the new job's record. On success the pair is committed as the skill's next version."""
        return self._enqueue(skill, request)

    def _enqueue(self, skill: str, request: AdaptJob | PairTrainJob) -> JobRecord:
        """Record a new queued job of ``request`` on ``skill`` and queue it, once its record is on
        disk. :class:`LearnerBusy` when ``max_queued_jobs`` jobs are unfinished,
        :class:`StateWriteError` when the record cannot be written (nothing queued either way)."""
        job = JobRecord.new(skill, request)
        with self._lock:
            self._check_room()
            self.job_store.save(job)
            self.jobs[job.job] = job
            self._wake.notify_all()
        return job

    def _check_room(self) -> None:
        """:class:`LearnerBusy` when ``max_queued_jobs`` jobs are unfinished."""
        with self._lock:
            limit = self.limits.max_queued_jobs
            if sum(j.state in UNFINISHED for j in self.jobs.values()) >= limit:
                raise LearnerBusy(busy_message(limit))

    def _persist(self, job: JobRecord, **changes) -> None:
        """Write ``job`` with ``changes`` (field values), then make them in memory: a failed write
        (:class:`StateWriteError`) leaves both the disk and the memory as they were."""
        with self._lock:
            new = dataclasses.replace(job, **changes)
            self.job_store.save(new)
            for name in changes:
                setattr(job, name, getattr(new, name))
            job.updated = new.updated

    def status(self, job_id: str) -> dict:
        """The status reply of job ``job_id``; :class:`UnknownJobError` if there is none."""
        with self._lock:
            job = self.jobs.get(job_id)
            if job is None:
                raise UnknownJobError(f"no job {job_id!r}")
            return job.status()

    def list_jobs(self, limit: int = 100) -> list[dict]:
        """The newest ``limit`` jobs' summaries (:meth:`JobRecord.summary`), newest first."""
        with self._lock:
            jobs = sorted(self.jobs.values(), key=lambda j: j.created, reverse=True)[:limit]
            return [job.summary() for job in jobs]

    def cancel(self, job_id: str) -> dict:
        """Cancel job ``job_id``; returns its status reply afterwards, once the cancel is on disk.

        A queued or interrupted job is ``cancelled`` at once; a running one gets
        ``cancel_requested`` and ends ``cancelled`` after its current iteration; a finished job
        is left as it is (its state answers). :class:`UnknownJobError` if there is none,
        :class:`StateWriteError` (nothing changed) when the record cannot be written.
        """
        with self._lock:
            job = self.jobs.get(job_id)
            if job is None:
                raise UnknownJobError(f"no job {job_id!r}")
            if job.state in TERMINAL:
                return job.status()
            now = job.job not in self._active  # not picked by the job loop: nothing to wait for
            self._persist(job, cancel_requested=True, **({"state": "cancelled"} if now else {}))
            status = job.status()
        if now:
            self._safe_progress(job, "cancelled")
            self._prune_jobs()
        log.info("job %s: cancel requested (%s)", job_id, status["state"])
        return status

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Block until no job is queued or running (True), or ``timeout`` passes (False). For tests."""
        end = None if timeout is None else time.monotonic() + timeout
        while True:
            with self._lock:
                if all(j.state not in UNFINISHED for j in self.jobs.values()):
                    return True
            if end is not None and time.monotonic() > end:
                return False
            time.sleep(0.05)

    def _prune_jobs(self) -> None:
        """Remove the records of finished jobs beyond ``keep_finished_jobs`` (the oldest first)
        and those unchanged for ``keep_finished_days``; a record that cannot be removed is kept."""
        with self._lock:
            finished = sorted((j for j in self.jobs.values() if j.state in TERMINAL and j.job not in self._active),
                              key=lambda j: j.updated or j.created)
            cutoff = time.time() - self.limits.keep_finished_days * 86400.0
            old = [j for j in finished if (j.updated or j.created) < cutoff]
            recent = [j for j in finished if (j.updated or j.created) >= cutoff]
            drop = old + recent[:max(0, len(recent) - self.limits.keep_finished_jobs)]
            for job in drop:
                try:
                    self.job_store.delete(job.job)
                except OSError as exc:
                    log.warning("could not remove the record of finished job %s: %s", job.job, exc)
                    continue
                del self.jobs[job.job]
        if drop:
            log.info("removed the records of %d finished job(s) (keeping %d, at most %g days)", len(drop),
                     self.limits.keep_finished_jobs, self.limits.keep_finished_days)

    def _next_job(self) -> str | None:
        """The oldest unfinished job no loop thread runs, marked active; None once stopping."""
        with self._lock:
            while not self._stop.is_set():
                for job in self.jobs.values():  # in the order they were queued
                    if job.state in UNFINISHED and job.job not in self._active:
                        self._active.add(job.job)
                        return job.job
                self._wake.wait(0.5)
        return None

    def _job_loop(self, runner: AdaptRunner) -> None:
        torch.set_num_threads(1)
        while not self._replayed.wait(0.2):
            if self._stop.is_set():
                return
        try:
            while (job_id := self._next_job()) is not None:
                try:
                    self._run_one(job_id, runner)
                finally:
                    with self._lock:
                        self._active.discard(job_id)
        except BaseException as exc:  # not a job's failure (those are caught below): say so in health
            self._loop_error = f"{type(exc).__name__}: {exc}"
            log.exception("the job loop stopped")  # logged once, here; the thread ends

    def _run_one(self, job_id: str, runner: AdaptRunner) -> None:
        """Run job ``job_id`` with ``runner`` and save how it ended; a job's failure never leaves here."""
        try:
            self._run_job(job_id, runner)
        except InterruptedError:  # shutting down: saved "interrupted", a restart resumes it
            log.info("job %s interrupted by shutdown", job_id)
            self._finish(job_id, "interrupted")
        except JobCancelled:
            log.info("job %s cancelled", job_id)
            self._finish(job_id, "cancelled")
        except Exception as exc:
            if self._stop.is_set():  # e.g. the session closing under a batch: not the job's fault
                log.info("job %s interrupted by shutdown (%s)", job_id, exc)
                self._finish(job_id, "interrupted")
                return
            if isinstance(exc, StateWriteError):  # the message says it all; no traceback
                log.error("job %s failed: %s", job_id, exc)
                error = str(exc)
            else:
                log.exception("job %s failed", job_id)
                error = f"{type(exc).__name__}: {exc}"
            self._finish(job_id, "failed", error=error)

    def _finish(self, job_id: str, state: str, **changes) -> None:
        """Save job ``job_id`` in ``state`` (with ``changes``) and publish its progress event. A
        terminal state is written however long the disk refuses it (retried; the loop waits), so
        it is never shown before it is durable; ``interrupted`` is tried once (the record left
        ``running`` is resumed the same way)."""
        with self._lock:
            job = self.jobs.get(job_id)
        if job is None:
            return
        delay = RETRY_FIRST
        while True:
            try:
                self._persist(job, state=state, **changes)
                break
            except StateWriteError as exc:
                if state not in TERMINAL or self._stop.is_set():
                    log.warning("job %s: %s; it is resumed at the next start", job_id, exc)
                    return
                if delay == RETRY_FIRST:
                    log.warning("job %s: %s; its %s state is saved as soon as the disk takes it", job_id, exc, state)
                if self._stop.wait(delay):
                    log.warning("job %s: stopped before its %s state could be saved; it is resumed at the next "
                                "start", job_id, state)
                    return
                delay = min(2 * delay, RETRY_MAX)
        self._safe_progress(job, state)
        if state in TERMINAL:
            self._prune_jobs()

    def _safe_progress(self, job: JobRecord, state: str) -> None:
        try:
            self.publish(self._progress_event(job, state))
        except Exception:
            log.exception("could not publish progress of %s", job.job)

    @staticmethod
    def _progress_event(job: JobRecord, state: str) -> dict:
        # events carry no lists: the excluded workers as one text, "<worker>: <why>; ..."
        now = job.exclusions()
        excluded = {"excluded_workers": "; ".join(e.line() for e in now)} if now else {}
        ev = job_progress_event(job.job, job.iteration, job.rollouts, job.best_return, state=state, skill=job.skill,
                                **excluded)
        ev["attempt"] = int(job.attempt)
        return ev

    def _note_exclusions(self, job: JobRecord, evaluator: RolloutEvaluator) -> dict:
        """The record changes that add the workers ``evaluator`` excluded (its ``excluded``, if it
        has one: the evaluator of the job's current attempt) to ``job``'s ``excluded_workers``,
        stamped with that attempt: ``{}`` when there is none new."""
        known = {e.worker for e in job.exclusions()}
        new = tuple(dataclasses.replace(e, attempt=job.attempt) for e in getattr(evaluator, "excluded", ())
                    if e.worker not in known)
        return {"excluded_workers": job.excluded_workers + new} if new else {}

    def _run_job(self, job_id: str, runner: AdaptRunner) -> None:
        with self._lock:
            job = self.jobs.get(job_id)
            if job is None or self._stop.is_set() or job.state not in UNFINISHED:
                return
            if job.cancel_requested:
                raise JobCancelled(job_id)
            # a record still "running" or "interrupted" (not re-queued at start): a new attempt
            attempt = job.attempt + (job.state in ("running", "interrupted"))
            if not isinstance(job.request, PairTrainJob):  # an adaptation, on a copy of its skill's model
                skill = self.skills.get(job.skill)
                if skill is None:  # e.g. none of its versions could be read at start
                    raise UnknownSkillError(f"no skill {job.skill!r} on this learner")
                model, demos, start_version = copy.deepcopy(skill.model), skill.demos, skill.version
            self._persist(job, state="running", attempt=attempt, attempt_start_index=job.next_index)
        if isinstance(job.request, PairTrainJob):
            self._run_pair(job)
            return
        req = job.request
        if job.result is None:
            self.publish(job_event(job.job, method=req.config.mode, robot=req.robot, task=req.task, skill=job.skill,
                                   seed=req.seed, attempt=job.attempt, config=req.config.to_dict(),
                                   task_config=req.task_config, output_names=model.config.output_names,
                                   task_param_names=model.config.task_param_names))
            evaluator = self.evaluator_for(req)
            on_iteration = self._recording(job, start_version, evaluator)
            task = AdaptTask(model, demos, req.target, req.config, req.seed,
                             credit=getattr(evaluator, "credit", "step"))
            try:
                job_result = runner.run(task, evaluator, on_iteration, self._stop)
            finally:  # the workers excluded in a batch that failed: named in the failed record too
                changes = self._note_exclusions(job, evaluator)
                if changes:
                    with contextlib.suppress(StateWriteError):  # the job's end writes its record again
                        self._persist(job, **changes)
            # adaptation done: a crash from here on only re-assimilates
            self._persist(job, rollouts=job_result.rollouts, result=job_result)
        if job.cancel_requested:  # asked for while the last iteration ran: do not assimilate
            raise JobCancelled(job_id)
        if req.commit and job.result.success:
            with self._lock:
                current = self.skills.get(job.skill)
            # the adapted copy found the solution; if the skill changed meanwhile, the new one trains on
            self._assimilate(job, model if current is not None and current.version == start_version else None)
        self._persist(job, state="done")
        self._safe_progress(job, "done")
        self._prune_jobs()

    def _run_pair(self, job: JobRecord) -> None:
        """Train ``job``'s transfer pair (from its beginning, with its seed: a restarted attempt
        gives the same pair), commit it as the skill's next version, mark the job done."""
        req: PairTrainJob = job.request
        if job.result is None:
            self.publish(job_event(job.job, method="train_pair", robot=req.robot_b, task="train_pair", skill=job.skill,
                                   seed=req.seed, attempt=job.attempt, config=req.config.to_dict()))
            pair = TransferPair(req.n_a, req.n_b, req.config, seed=req.seed)
            with self._train_lock:
                losses = train_pair(pair, req.demos_a, req.demos_b, req.config, seed=req.seed,
                                    on_step=self._pair_progress(job))
            # a pair trains on the CPU (acnmp_core/transfer/pair.py); served and adapted where the skills are
            pair.model_a.to_device(self.device)
            pair.model_b.to_device(self.device)
            with self._lock:
                state = SkillState(job.skill, pair.model_a, req.demos_a, self.skill_store.next_version(job.skill),
                                   partner=pair.model_b, partner_demos=req.demos_b,
                                   source_hash=req.demos_a.content_hash())
                self._commit_skill(state, (req.robot_a, req.robot_b), loss=losses.nll_b[-1] if losses.nll_b else None,
                                   note=f"paired skill trained by {job.job}")
                job.committed_version = state.version  # committed (durable): written with the next record
                self._persist(job, result=PairJobResult.from_losses(state.version, losses), state="done")
        self._safe_progress(job, "done")
        self._prune_jobs()

    def _pair_progress(self, job: JobRecord) -> Callable[[int, PairTrainResult], None]:
        """``on_step`` of a pair training: every ~5 % of the steps the job's ``iteration`` (steps
        done) is saved and a progress event published; stops the training (InterruptedError,
        :class:`JobCancelled`) when the learner closes or the job is cancelled."""
        every = max(1, job.request.config.steps // 20)

        def on_step(done: int, losses: PairTrainResult) -> None:
            if self._stop.is_set():
                raise InterruptedError("learner is shutting down")
            if job.cancel_requested:
                raise JobCancelled(job.job)
            if done % every and done != job.request.config.steps:
                return
            self._persist(job, iteration=done)
            ev = self._progress_event(job, "running")
            ev["loss"] = float(losses.nll_a[-1] + losses.nll_b[-1])
            self.publish(ev)
            steps = job.request.config.steps
            self.metrics.report(job.job, "train_pair", done, {"nll_a": losses.nll_a[-1], "nll_b": losses.nll_b[-1]},
                                f"job {job.job}: pair training step {done}/{steps}, nll A {losses.nll_a[-1]:.4f}, "
                                f"B {losses.nll_b[-1]:.4f}", last=done == steps)

        return on_step

    def _recording(self, job: JobRecord, model_version: int,
                   evaluator: RolloutEvaluator) -> Callable[[IterationLog, np.ndarray, RolloutBatch], None]:
        """The ``on_iteration`` callback of ``job``'s adaptation of the skill's ``model_version`` with
        ``evaluator``: bookkeeping (the workers it excluded too), then one rollout event per executed
        trajectory and a progress event; raises InterruptedError once closing."""
        target: AdaptTarget = job.request.target
        drawing = robot_drawing(job.request.robot)
        # a drawn robot shows its own states; a point robot shows the conditioning points instead
        condition = None if drawing is not None else {"times": target.obs_times, "values": target.obs_values}

        def on_iteration(it_log: IterationLog, trajectories: np.ndarray, batch: RolloutBatch) -> None:
            if self._stop.is_set():
                raise InterruptedError("learner is shutting down")
            first = job.next_index
            best = float(np.max(batch.returns))
            events = batch_rollout_events(job.job, first, trajectories, target.query_times, batch,
                                          task_params=target.task_params, condition=condition,
                                          iteration=it_log.iteration, skill=job.skill, drawing=drawing)
            for ev in events:
                ev["attempt"] = int(job.attempt)
                ev["model_version"] = int(model_version)
            # the events on disk (beside those the recorder has not confirmed yet), then their indices
            # reserved, then published: a learner killed anywhere, the recorder with it or not,
            # publishes them at its next start (a failed write fails the job)
            self.journals.save(job.job, events)
            self._persist(job, next_index=first + len(batch), iteration=it_log.iteration, rollouts=it_log.rollouts,
                          best_return=best if job.best_return is None else max(job.best_return, best),
                          **self._note_exclusions(job, evaluator))
            for ev in events:
                self.publish(ev)
            self.publish(self._progress_event(job, "running"))
            std = float(np.mean(it_log.explore_std)) if len(it_log.explore_std) else None
            self.metrics.report(
                job.job, "adapt", it_log.iteration,
                {"mean_return": it_log.mean_return, "best_return": job.best_return, "explore_std": std,
                 "rollouts": it_log.rollouts, "mean_success": float(it_log.mean_success),
                 "mean_error": it_log.mean_error},
                f"job {job.job}: iteration {it_log.iteration}, {it_log.rollouts}/{job.request.config.max_rollouts} "
                f"roll-outs, mean return {it_log.mean_return:.4g}, best {job.best_return:.4g}"
                + ("" if std is None else f", exploration std {std:.3g}"),
                last=bool(it_log.mean_success))
            if job.cancel_requested:  # this iteration's roll-outs are recorded; no further one runs
                raise JobCancelled(job.job)

        return on_iteration

    def _assimilate(self, job: JobRecord, adapted: CNMP | None) -> None:
        """Add the job's solution to the skill's demos, train on, commit a new version (once);
        :class:`StateWriteError` (nothing committed) when its checkpoint cannot be written."""
        res, req = job.result, job.request
        traj, times = res.trajectory, res.times
        with self._lock:
            skill = self.skills.get(job.skill)
            if skill is None:
                raise UnknownSkillError(f"no skill {job.skill!r} on this learner")
            last = skill.demos[len(skill.demos) - 1]
            if last.values.shape == traj.shape and np.array_equal(last.values, traj) \
                    and np.array_equal(last.times, times):
                job.committed_version = skill.version  # committed before a crash; do not add it twice
                return
            model = adapted if adapted is not None else copy.deepcopy(skill.model)
            tp = req.target.task_params
            params = np.zeros(skill.demos.n_task_params) if tp is None else tp
            old_demos = skill.demos
        with self._train_lock:
            # stopped by a shutdown: the job is saved interrupted and re-assimilates at the next start
            demos, _ = assimilate(model, old_demos, Demonstration(times, traj, params),
                                  AssimilationConfig(steps=req.assimilate_steps), conditions=req.target,
                                  seed=req.seed + 1, stop=self._stop)
        with self._lock:
            state = SkillState(skill.name, model, demos, self.skill_store.next_version(skill.name),
                               source_hash=skill.source_hash)  # demos = the skill's + the solution
            self._commit_skill(state, note=f"assimilated {job.job}")
            job.committed_version = state.version  # committed (durable): written with the job's next record

    def interrupt(self) -> None:
        """Ask the work in progress to stop at its next step (a job's iteration or batch, a training,
        an assimilation: InterruptedError there) and start no more; :meth:`close` still has to be
        called. A service calls it as soon as it is told to stop, so nothing holds its shutdown."""
        self._stop.set()
        with self._lock:
            self._wake.notify_all()

    def close(self, timeout: float = 10.0, before_unlock: Callable[[], None] | None = None) -> None:
        """Stop running jobs: the running one is interrupted (at its next iteration, or at once by an
        evaluator watching :attr:`stopping`), saved ``interrupted``, and resumes on restart.
        ``before_unlock`` runs once the jobs have stopped, while the state directory is still
        locked (the service confirms what was recorded there, :meth:`settle_journals`)."""
        self._stop.set()
        with self._lock:
            self._wake.notify_all()
        end = time.monotonic() + timeout
        for thread in (self._replayer, *self._threads):
            if thread.is_alive():
                thread.join(timeout=max(0.0, end - time.monotonic()))
        for runner in self._runners:
            runner.close()
        try:
            if before_unlock is not None:
                before_unlock()
        finally:
            self._dir_lock.release()
