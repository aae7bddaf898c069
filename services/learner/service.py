"""The learner process: the zenoh side of :class:`~services.learner.core.LearnerCore`.

Declared entities (``<ns>`` namespace; docs/PROTOCOL.md has every field):

- queryables ``acnmp/<ns>/skill/*/train`` (train a skill from demonstrations -> new version),
  ``acnmp/<ns>/skill/*/train_pair`` (queue a paired skill's training -> job id),
  ``acnmp/<ns>/skill/*/adapt`` (queue an adaptation job -> job id), ``acnmp/<ns>/job/*/status``,
  ``acnmp/<ns>/job/*/cancel`` (cancel a job -> its status) and ``acnmp/<ns>/skill/*/weights/latest`` (a wildcard query gets one reply per skill);
- puts: weights messages on ``acnmp/<ns>/skill/<skill>/weights`` (services/model/weights.py), and
  the core's events (services/recording/events.py): ``model_version`` per version, per job one
  ``rollout`` per executed trajectory and one ``job_progress`` per iteration;
- liveliness token ``acnmp/<ns>/learner/<id>`` once all of the above exist.

Its health (the ``problems`` of its ``about`` reply, what ``acnmp status`` shows): a state write
that failed, a job loop that stopped, the files in its state directory's quarantine. A job loop
that stops by an error ends the process (exit 1), so a launcher restarts it.

``--demos`` skills whose file changed since they were trained are **withheld** until retrained:
``weights/latest`` does not answer them, so a model service starting meanwhile serves the skill
only once it is the one trained from the file (``acnmp up`` says "deployment is up" then).

An adapt request is decoded once into an :class:`~acnmp_core.jobs.adapt.AdaptJob`
(:meth:`~acnmp_core.jobs.adapt.AdaptJob.from_dict`); the core runs it with a
:class:`~services.worker.remote.RemoteEvaluator` over the workers of the job's robot kind.
"""
from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import zenoh

from acnmp_core.data.demos import DemoSet
from acnmp_core.jobs.adapt import AdaptJob
from acnmp_core.jobs.transfer import PairTrainJob
from acnmp_core.model.cnmp import CNMPConfig
from acnmp_core.model.training import TrainConfig
from services.model.weights import encode_weights
from services.recording.event_ids import IndexRanges
from services.recording.publisher import EventPublisher
from services.transport import Keyspace, Ready, WireError, declare_rpc
from services.transport.errors import wire_error
from services.transport.keys import check_name, is_concrete, job_from_key, skill_from_key, token_id
from services.transport.rpc import NotServed
from services.transport.state_dir import default_state_dir
from services.transport.wire import array_field, error_payload, field, require_payload
from services.worker.exclusion import WorkerExclusions
from services.worker.remote import RemoteEvaluator

from .core import LearnerBusy, LearnerCore, TrainSpec, UnknownJobError, UnknownSkillError
from .limits import LearnerLimits, StateLimits, check_job, check_pair, check_train
from .config import LearnerOptions, demos_skill, load_demos_spec, parse_demos_spec
from .ownership import Ownership, skill_of_job
from .runner import fork_children
from .store import SkillState, StateWriteError

log = logging.getLogger(__name__)

#: Seconds a closing learner waits for the recorder to confirm its roll-outs (well inside the
#: launcher's stop timeout, after which it is SIGKILLed).
RECORDED_WAIT = 4.0

#: Seconds between looks at the finished jobs' journals (doubling up to SETTLE_MAX while some stay).
SETTLE_FIRST, SETTLE_MAX = 1.0, 30.0

#: Bound on the demonstrations of one train request (N * T * D values).
MAX_DEMO_VALUES = 10_000_000
#: Jobs a ``jobs`` query lists when it does not say (``limit``), and at most.
DEFAULT_JOB_LIST = 100
MAX_JOB_LIST = 1000
#: Model-architecture fields a train request may set (the rest come from the data).
MODEL_FIELDS = ("encoder_widths", "decoder_widths", "std_floor", "prior", "prior_basis", "prior_clip")
TRAIN_FIELDS = tuple(f.name for f in dataclasses.fields(TrainConfig))


def _overrides(msg: dict, key: str, allowed: Sequence[str]) -> dict:
    """The map ``msg[key]`` (default {}) checked to hold only ``allowed`` keys of plain values."""
    value = field(msg, key, dict, default={})
    unknown = sorted(set(value) - set(allowed))
    if unknown:
        raise WireError("bad_request", f"field '{key}': unknown setting(s) {unknown}; allowed: {list(allowed)}")
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in value.items()}


def parse_train_request(msg: dict | None, limits: LearnerLimits = LearnerLimits()) -> TrainSpec:
    """Validate a train request; returns a :class:`TrainSpec`. Raises WireError.

    Request: ``times`` (N,T) or (T,), ``values`` (N,T,D), ``task_params`` (N,P) optional,
    ``value_names`` (D,) / ``task_param_names`` (P,) optional lists of str, ``model`` (overrides
    of encoder_widths, decoder_widths, std_floor), ``train`` (TrainConfig overrides), ``seed`` int.
    The model's size and the training's cost are checked against ``limits`` (``too_large``).
    """
    msg = require_payload(msg, "a train request")
    values = array_field(msg, "values", ndim=3, max_elements=MAX_DEMO_VALUES)
    n, t, d = values.shape
    if n < 1 or t < 2 or d < 1:
        raise WireError("bad_shape", f"field 'values': shape {values.shape}, need N>=1, T>=2, D>=1")
    times = array_field(msg, "times", ndim=(1, 2))
    if times.shape not in ((t,), (n, t)):
        raise WireError("bad_shape", f"field 'times': expected ({t},) or ({n}, {t}), got {times.shape}")
    tp = array_field(msg, "task_params", ndim=2, default=None, max_elements=n * 1024)
    if tp is not None and tp.shape[0] != n:
        raise WireError("bad_shape", f"field 'task_params': expected {n} rows, got {tp.shape[0]}")
    try:
        demos = DemoSet.from_arrays(times, values, tp)
    except ValueError as exc:
        raise WireError("bad_request", f"demonstrations: {exc}") from None
    model_cfg = _overrides(msg, "model", MODEL_FIELDS)
    for key, count in (("value_names", d), ("task_param_names", demos.n_task_params)):
        names = field(msg, key, list, default=None)
        if names is not None:
            if len(names) != count or not all(isinstance(s, str) for s in names):
                raise WireError("bad_request", f"field '{key}': expected {count} strings")
            model_cfg["output_names" if key == "value_names" else key] = names
    try:
        cnmp_cfg = CNMPConfig(n_outputs=d, n_task_params=demos.n_task_params, **model_cfg)
        train_cfg = TrainConfig(**_overrides(msg, "train", TRAIN_FIELDS))
    except (TypeError, ValueError) as exc:
        raise WireError("bad_request", f"settings: {exc}") from None
    if train_cfg.max_obs + 1 > t:
        raise WireError("bad_request", f"train.max_obs: demonstrations of {t} points need max_obs < {t}")
    check_train(cnmp_cfg, train_cfg, limits)
    return TrainSpec(demos, cnmp_cfg, train_cfg, field(msg, "seed", int, default=0))


def parse_pair_request(msg: dict | None, limits: LearnerLimits = LearnerLimits()) -> PairTrainJob:
    """Validate a ``train_pair`` request (docs/PROTOCOL.md; the layout of
    :class:`~acnmp_core.jobs.transfer.PairTrainJob`); returns the job. Raises WireError: the code of
    the library's typed error (``bad_shape``, ``non_finite``, ``too_large``, else ``bad_request``),
    or ``too_large`` over a limit of the learner."""
    msg = require_payload(msg, "a train_pair request")
    try:
        job = PairTrainJob.from_dict(msg)
    except ValueError as exc:
        raise wire_error(exc, default="bad_request") from None
    check_pair(job, limits)
    return job


class LearnerService:
    """The learner's queryables, token and weights puts on an open session, around a :class:`LearnerCore`.

    Parameters
    ----------
    session : open zenoh session (closed by the caller after :meth:`close`).
    keys : the deployment's :class:`Keyspace`. state_dir : where skills and jobs are checkpointed.
    learner_id : liveliness id. wait_recorder : seconds to wait for a recorder before the first
        event (0: do not wait; events published with no recorder are simply not recorded).
    chunk_timeout : seconds a worker may take for its share of a batch before it is re-sent.
    limits : what one train or adapt request may cost (services/learner/limits.py).
    state_limits : queue limit, job records and checkpoints kept (services/learner/limits.py).
    demos : the ``--demos`` values ``SKILL=FILE.npz`` the caller will :func:`bootstrap`: a skill
        whose file changed is withheld from ``weights/latest`` until it is retrained.
    ready : the process's :class:`~services.transport.Ready`: the learner reports its health
        through it before its token appears.
    jobs, job_runner : how many jobs run at once, and where their adaptations compute
        (:class:`~services.learner.core.LearnerCore`, services/learner/runner.py).
    learners : the ids of every learner of the deployment when it runs several (``learner_id``
        among them): this one answers only for the skills it owns (services/learner/ownership.py).
    cross_check : the fraction of roll-out chunks run again on a second worker (besides every
        chunk whose success would end its job when > 0); services/worker/remote.py.
    """

    def __init__(self, session: zenoh.Session, keys: Keyspace, state_dir: str | os.PathLike, *,
                 learner_id: str | None = None, wait_recorder: float = 0.0, chunk_timeout: float = 60.0,
                 limits: LearnerLimits = LearnerLimits(), device: str = "cpu",
                 state_limits: StateLimits = StateLimits(), demos: Sequence[str] = (), ready: Ready | None = None,
                 jobs: int = 1, job_runner: str = "thread", learners: Sequence[str] = (), cross_check: float = 0.0):
        self.session, self.keys = session, keys
        self.limits = limits
        self.learner_id = check_name("learner id", learner_id or f"learner-{os.getpid()}")
        self.ownership = Ownership(self.learner_id, learners)
        self.events = EventPublisher(session, keys)
        self.wait_recorder = float(wait_recorder)
        self.chunk_timeout = float(chunk_timeout)
        self.cross_check = float(cross_check)
        #: workers a job excluded lately: the other jobs avoid them for a while (services/worker/exclusion.py)
        self.exclusions = WorkerExclusions()
        self._recorder_checked = wait_recorder <= 0
        self.core = LearnerCore(state_dir, evaluator_for=self._evaluator, publish=self._publish,
                                on_version=self._put_weights, device=device, state_limits=state_limits,
                                jobs=jobs, job_runner=job_runner)
        if ready is not None:
            ready.report_health(lambda: self.core.health().problems())
        #: the --demos values of the skills this learner serves (the others' owners train theirs)
        self.demos = [spec for spec in demos if self.ownership.owner(demos_skill(spec)) == self.learner_id]
        #: skills not served until retrained from their changed --demos file
        self.withheld: set[str] = stale_skills(self.core, self.demos)
        self._learners_sub = None if self.ownership.alone else session.liveliness().declare_subscriber(
            keys.learner_token("*"), self._learner_token, history=True)
        # with several learners every one must get each query (its skill's owner answers it): a
        # complete queryable would let the router pick one of them
        complete = self.ownership.alone
        self._rpcs = [
            declare_rpc(session, keys.train("*"), self._handle_train, workers=1, complete=complete),
            declare_rpc(session, keys.adapt("*"), self._handle_adapt, workers=1, complete=complete),
            declare_rpc(session, keys.train_pair("*"), self._handle_train_pair, workers=1, complete=complete),
            declare_rpc(session, keys.job_status("*"), self._handle_status, workers=1, complete=complete),
            declare_rpc(session, keys.job_cancel("*"), self._handle_cancel, workers=1, complete=complete),
            declare_rpc(session, keys.jobs(), self._handle_jobs, workers=1, complete=complete),
        ]
        self.refused_keys = 0  # weights/latest queries on other wildcards, dropped
        self._latest = session.declare_queryable(keys.weights_latest("*"), self._handle_latest)
        self.core.start()
        self._settler = threading.Thread(target=self._settle_loop, name="journals-settle", daemon=True)
        self._settler.start()
        self.token_key = keys.learner_token(self.learner_id)
        self._token = session.liveliness().declare_token(self.token_key)

    @property
    def skills(self) -> dict[str, SkillState]:
        """The core's skills by name."""
        return self.core.skills

    # ----- the jobs' journals ----------------------------------------------------------------
    def _held(self, jobs: list[str]) -> dict[str, IndexRanges]:
        """Per job of ``jobs``, the roll-out indices the recording's files hold (the recorder's
        status, services/recording/publisher.py); every index when the learner does not record
        (no recorder to wait for)."""
        if self.wait_recorder <= 0:
            return {job: IndexRanges.everything() for job in jobs}
        return self.events.held(jobs)

    def _settle_loop(self) -> None:
        """Drop from the jobs' journals the roll-outs the recorder holds, and remove the journals of
        finished jobs left with none (so a later session publishes no fragment of them into its
        recording): every second while the recorder confirms some or none waits, backing off to
        :data:`SETTLE_MAX` s while it confirms none (it is unreachable)."""
        delay = SETTLE_FIRST
        while not self.core.stopping.wait(delay):
            try:
                settled = self.core.settle_journals(self._held)
                progress = settled.confirmed > 0 or not settled.waiting
            except Exception:  # a session closing under us: tried again
                log.debug("settling the jobs' journals failed", exc_info=True)
                progress = False
            delay = SETTLE_FIRST if progress else min(2 * delay, SETTLE_MAX)

    # ----- what the core calls ---------------------------------------------------------------
    def _evaluator(self, job: AdaptJob) -> RemoteEvaluator:
        # a job that stops on success ends on one chunk's word: that chunk is always checked
        return RemoteEvaluator(self.session, self.keys, job.robot, job.task, dict(job.task_config),
                               timeout=self.chunk_timeout, stop=self.core.stopping, exclusions=self.exclusions,
                               cross_check=self.cross_check,
                               check_success=self.cross_check > 0 and job.config.stop_on_success)

    def _publish(self, event: dict) -> None:
        if not self._recorder_checked:
            self._recorder_checked = True
            if not self.events.wait_for_recorder(self.wait_recorder):
                log.warning("no recorder live after %.0fs: events are not recorded", self.wait_recorder)
        self.events.publish(event)

    def _put_weights(self, state: SkillState) -> None:
        self.withheld.discard(state.name)  # a new version: the one asked for
        self.session.put(self.keys.weights(state.name), _weights(state),
                         congestion_control=zenoh.CongestionControl.BLOCK)

    # ----- handlers --------------------------------------------------------------------------
    @staticmethod
    def _skill_of(query: zenoh.Query, msg: dict | None = None) -> str:
        try:
            skill = skill_from_key(str(query.key_expr))
        except ValueError as exc:
            raise WireError("bad_request", str(exc)) from None
        if msg is not None and msg.get("skill") not in (None, skill):
            raise WireError("bad_request", f"field 'skill': {msg['skill']!r} differs from the key's {skill!r}")
        return skill

    def _learner_token(self, sample: zenoh.Sample) -> None:
        lid = token_id(sample.key_expr, self.keys.learner_token("*"))
        if lid is not None:
            self.ownership.token_changed(lid, sample.kind == zenoh.SampleKind.PUT)

    def _check_owner(self, skill: str) -> None:
        """Return if this learner serves ``skill``; :class:`NotServed` when its live owner answers;
        ``unavailable`` naming the owner when that one is not live."""
        decision = self.ownership.decide(skill)
        if decision == "drop":
            raise NotServed(skill)
        if decision != "serve":
            raise WireError("unavailable", f"skill {skill!r} is served by learner {decision!r}, which is not live; "
                                           "its skills and jobs are back when it restarts")

    def _handle_train(self, msg: dict | None, query: zenoh.Query) -> dict:
        skill = self._skill_of(query, msg)
        self._check_owner(skill)
        spec = parse_train_request(msg, self.limits)
        state = self.core.trained_from(skill, spec) if field(msg, "reuse", bool, default=False) else None
        trained = state is None
        if trained:
            try:
                state = self.core.train_skill(skill, spec)
            except InterruptedError:  # the learner is stopping: a restarted one trains it when asked again
                raise WireError("unavailable", "the learner is shutting down; send the request again") from None
            except StateWriteError as exc:
                raise WireError("write_failed", f"{exc}; nothing was committed") from None
        return {"v": 1, "skill": skill, "version": state.version, "data_hash": state.demos.content_hash(),
                "n_demos": len(state.demos), "trained": trained}

    def _handle_adapt(self, msg: dict | None, query: zenoh.Query) -> dict:
        skill = self._skill_of(query, msg)
        self._check_owner(skill)
        msg = require_payload(msg, "an adapt request")
        try:
            job = AdaptJob.from_dict(msg)
            check_job(job, self.limits)
            with _storage_errors("the job was not queued"):
                job = self.core.submit(skill, job)
        except UnknownSkillError as exc:
            raise WireError("unknown_skill", str(exc)) from None
        except ValueError as exc:  # typed errors keep their code; the model's own checks are bad_request
            raise wire_error(exc, default="bad_request") from None
        return {"v": 1, "job": job.job, "skill": skill, "state": job.state}

    def _handle_train_pair(self, msg: dict | None, query: zenoh.Query) -> dict:
        skill = self._skill_of(query, msg)
        self._check_owner(skill)
        request = parse_pair_request(msg, self.limits)
        with _storage_errors("the job was not queued"):
            job = self.core.submit_pair(skill, request)
        return {"v": 1, "job": job.job, "skill": skill, "state": job.state}

    def _handle_status(self, _msg, query: zenoh.Query) -> dict:
        return self._job_reply(self.core.status, query)

    def _handle_jobs(self, msg: dict | None, _query: zenoh.Query) -> dict:
        limit = (msg or {}).get("limit", DEFAULT_JOB_LIST)
        if isinstance(limit, bool) or not isinstance(limit, int) or not 1 <= limit <= MAX_JOB_LIST:
            raise WireError("bad_request", f"field 'limit': expected an integer in 1..{MAX_JOB_LIST}, got {limit!r}")
        # who answers, and whom it sees live: a client merges replies until every live learner's is in
        return {"v": 1, "jobs": self.core.list_jobs(limit), "total": len(self.core.jobs),
                "learner": self.learner_id, "live": self.ownership.live()}

    def _handle_cancel(self, _msg, query: zenoh.Query) -> dict:
        with _storage_errors("the job was not cancelled"):
            return self._job_reply(self.core.cancel, query)

    def _job_reply(self, action, query: zenoh.Query) -> dict:
        """``action(job id)`` for the job named by the query's key (if this learner owns its
        skill), errors mapped to wire codes."""
        try:
            job = job_from_key(str(query.key_expr))
        except ValueError as exc:
            raise WireError("bad_request", str(exc)) from None
        self._check_owner(skill_of_job(job))
        try:
            return action(job)
        except UnknownJobError as exc:
            raise WireError("unknown_job", str(exc)) from None
        except ValueError as exc:
            raise WireError("bad_request", str(exc)) from None

    def _handle_latest(self, query: zenoh.Query) -> None:
        # hand-written (not declare_rpc): a wildcard query, as the model service sends at start,
        # gets one reply per skill on that skill's concrete key
        # (any key expression that intersects ours, e.g. acnmp/**, gets the skills it matches)
        with query:
            if not (is_concrete(query.key_expr) or str(query.key_expr) == self.keys.weights_latest("*")):
                self.refused_keys += 1  # only one skill's key, or every skill's (the model at start)
                return
            try:
                asked = query.key_expr
                states = [state for name, state in sorted(self.core.skill_states().items())
                          if name not in self.withheld and self.ownership.owner(name) == self.learner_id
                          and asked.intersects(zenoh.KeyExpr(self.keys.weights_latest(name)))]
                if not states and "*" not in str(asked):  # a wildcard matching nothing gets no reply
                    query.reply_err(error_payload("unknown_skill", f"no skill matching {str(asked)!r} on this learner"))
                    return
                for state in states:
                    query.reply(self.keys.weights_latest(state.name), _weights(state))
            except Exception as exc:
                log.exception("weights/latest failed")
                query.reply_err(error_payload("internal", f"{type(exc).__name__}: {exc}"))

    def close(self) -> None:
        """Stop taking requests, interrupt the running job (it resumes on restart), undeclare all;
        with a recorder (``wait_recorder`` > 0), wait up to :data:`RECORDED_WAIT` s until it holds
        every roll-out this learner published (the launcher stops it only after the learner).
        The liveliness token goes last: a recorder whose launcher died records until it is gone."""
        self.core.interrupt()  # first: a handler training would hold the undeclaring of its queryable
        subs = () if self._learners_sub is None else (self._learners_sub.undeclare,)
        for undeclare in (*(rpc.close for rpc in self._rpcs), self._latest.undeclare, *subs):
            try:
                undeclare()
            except Exception:  # the session may be closing under us
                log.debug("undeclare failed", exc_info=True)
        self.core.close(before_unlock=self._wait_recorded)
        self._settler.join(timeout=5.0)
        try:
            self._token.undeclare()
        except Exception:
            log.debug("undeclare failed", exc_info=True)

    def _wait_recorded(self) -> None:
        """With a recorder (``wait_recorder`` > 0): wait up to :data:`RECORDED_WAIT` s until it holds
        every roll-out this learner published; then drop from the journals what its files hold
        (every roll-out without a recorder), removing the finished jobs' journals left empty."""
        started = time.monotonic()
        if self.wait_recorder > 0 and not self.events.wait_recorded(RECORDED_WAIT):
            waited = time.monotonic() - started
            if waited < RECORDED_WAIT:  # said at once: nothing answered
                log.warning("no recorder answered (after %.1f s; the router may be gone with the launcher that held "
                            "it): this learner's last events may be missing from the recording, its job records "
                            "hold the jobs' states and its journals the roll-outs, published at its next start",
                            waited)
            else:
                log.warning("the recorder did not confirm every roll-out of this learner within %.0f s", RECORDED_WAIT)
        try:
            self.core.settle_journals(self._held)
        except Exception:  # the session closing under us: the journals stay, published at the next start
            log.debug("settling the jobs' journals at the stop failed", exc_info=True)

    def __enter__(self) -> "LearnerService":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@contextlib.contextmanager
def _storage_errors(what: str):
    """Answer a request refused by the learner's bounds or disk: ``busy`` (queue limit) or
    ``write_failed`` (the record could not be written; ``what`` says what did not happen)."""
    try:
        yield
    except LearnerBusy as exc:
        raise WireError("busy", str(exc)) from None
    except StateWriteError as exc:
        raise WireError("write_failed", f"{exc}; {what}") from None


def _weights(state: SkillState) -> bytes:
    """The encoded weights message of a skill version (a paired skill's with robot B's model)."""
    return encode_weights(state.name, state.version, state.model, data_hash=state.demos.content_hash(),
                          n_demos=len(state.demos), partner=state.partner)


def bootstrap(core: LearnerCore, specs: Sequence[str], steps: int) -> list[str]:
    """Train each ``SKILL=FILE.npz`` demonstration file (``--demos``) that is not a skill yet, or
    whose skill was trained from other demonstrations (the file changed since: the skill is
    retrained from it as its next version, and a warning says so). A skill trained from the
    file's demonstrations, adapted and assimilated since or not, is kept. Returns one line per
    skill saying which happened (also logged)."""
    lines = []
    for spec in specs:
        name = parse_demos_spec(spec)
        path = spec.partition("=")[2]
        arrays = load_demos_spec(spec)
        demos = arrays.to_demo_set()
        old = core.skills.get(name)
        if old is not None and trained_from(old, demos):
            lines.append(f"skill {name}: version {old.version} was trained from {path}; kept")
            log.info("%s", lines[-1])
            continue
        cfg = CNMPConfig(n_outputs=demos.n_outputs, n_task_params=demos.n_task_params,
                         output_names=() if arrays.value_names is None else tuple(arrays.value_names),
                         task_param_names=() if arrays.task_param_names is None else tuple(arrays.task_param_names))
        if old is not None:
            log.warning("skill %s: version %d was trained from other demonstrations than %s (data hash %s); "
                        "retraining it from %s (it is not served until then)", name, old.version, path,
                        demos.content_hash()[:12], path)
        state = core.train_skill(name, TrainSpec(demos, cfg, TrainConfig(steps=steps)))
        lines.append(f"skill {name}: version {state.version} trained from {path}"
                     + ("" if old is None else " (retrained: the file's demonstrations changed)"))
        log.info("%s", lines[-1])
    return lines


def stale_skills(core: LearnerCore, specs: Sequence[str]) -> set[str]:
    """The skills of ``--demos`` values ``specs`` that :func:`bootstrap` will retrain: those the
    learner holds, trained from other demonstrations than their file's now (a file that cannot be
    read is left to :func:`bootstrap`, which says so)."""
    out = set()
    for spec in specs:
        try:
            name, demos = parse_demos_spec(spec), load_demos_spec(spec).to_demo_set()
        except ValueError:
            continue
        old = core.skills.get(name)
        if old is not None and not trained_from(old, demos):
            out.add(name)
    return out


def trained_from(state: SkillState, demos: DemoSet) -> bool:
    """Whether skill ``state`` was trained from ``demos``: its recorded source hash, or (a skill
    saved without one) its demonstrations beginning with them (assimilation appends)."""
    if state.source_hash is not None:
        return state.source_hash == demos.content_hash()
    head = state.demos.demos[:len(demos)]
    return len(head) == len(demos) and DemoSet(head).content_hash() == demos.content_hash()


@dataclass
class LearnerConfig(LearnerOptions):
    """The learner process: its options (:class:`~services.learner.config.LearnerOptions`) and
    :meth:`serve`, which runs it on an open session."""

    def prepare(self) -> None:
        """With job processes: fork them now, before the session exists (services/learner/runner.py),
        so every child shares the learner's imported torch and starts its first job at once."""
        if self.job_runner == "process":
            fork_children(self.jobs)

    def serve(self, session: zenoh.Session, stop: threading.Event, ready: Ready) -> int:
        import torch

        torch.set_num_threads(1)
        state_dir = self.state_dir or default_state_dir(self.session.namespace, say=log.warning)
        state_limits = StateLimits(max_queued_jobs=self.max_queued_jobs, keep_finished_jobs=self.keep_jobs,
                                   keep_finished_days=self.keep_job_days, keep_versions=self.keep_versions)
        with LearnerService(session, Keyspace(self.session.namespace), state_dir, learner_id=self.learner_id,
                            wait_recorder=self.wait_recorder, chunk_timeout=self.chunk_timeout,
                            limits=LearnerLimits(max_train_steps=self.max_train_steps,
                                                 max_rollouts=self.max_rollouts), device=self.device,
                            state_limits=state_limits, demos=self.demos, ready=ready, jobs=self.jobs,
                            job_runner=self.job_runner, learners=self.learners,
                            cross_check=self.cross_check) as learner:
            # a stop interrupts what the core runs at once (training included), not after it
            threading.Thread(target=lambda: (stop.wait(), learner.core.interrupt()), name="stop-watch",
                             daemon=True).start()
            try:
                booted = bootstrap(learner.core, learner.demos, self.train_steps)
            except InterruptedError:
                log.info("stopped while training the --demos skills; they are trained at the next start")
                return 0
            found = learner.core.state.found
            ready(f"learner live as {learner.token_key}; skills: {sorted(learner.skills) or 'none yet'}; "
                  f"state in {Path(state_dir).resolve()}" + "".join(f"; {line}" for line in booted)
                  + (f"; {len(found)} file(s) quarantined at start" if found else ""))
            while not stop.wait(0.2):
                error = learner.core.loop_error
                if error is not None:  # exit, so a launcher restarts it with a working loop
                    log.error("the job loop has stopped (%s): exiting", error)
                    return 1
        return 0
