"""A Python client for an ACNMP deployment: predict/info on the model service, train/adapt/job
status on the learner (key expressions and messages: docs/PROTOCOL.md).

    with ACNMPClient() as client:          # the deployment `acnmp up` runs (its run file)
        p = client.predict("reach", obs_times=[0.0], obs_values=[[0.0, 0.0]], n_steps=200)
        p.mean  # (200, 2) numpy array, raw units

Every error reply becomes a :class:`ClientError` carrying the service's code
(services/transport/wire.py ``ERROR_CODES``) and message; nothing answering is ``unavailable``, no
answer in time ``timeout``; a query answered ``unavailable`` is retried until its timeout (the
service may still be appearing; clients/discovery.py). Queries go through the transport's one RPC
caller (:func:`services.transport.rpc.call`).
"""
from __future__ import annotations

import contextlib
import itertools
import threading
import time
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
import zenoh

from acnmp_core.jobs.adapt import AdaptJob
from acnmp_core.jobs.transfer import PairTrainJob
from services.transport import DEFAULT_NAMESPACE, Keyspace, WireError, alive_tokens, open_session
from services.transport.keys import is_concrete, last_chunk
from services.transport.rpc import call, call_all
from services.worker.exclusion import Exclusion

from .discovery import call_when_available, resolve

#: The default router address of the compose deployment (``ACNMP_CONNECT=tcp/127.0.0.1:7447``).
DEFAULT_CONNECT = "tcp/127.0.0.1:7447"

TERMINAL_JOB_STATES = ("done", "failed", "cancelled")
#: Error codes that mean "nobody answered now" (a service restarting), not "the request is wrong".
RETRY_CODES = ("unavailable", "timeout")


#: An error reply (or no reply) from the deployment: ``code`` and ``message`` as on the wire.
ClientError = WireError


@dataclass
class PredictResult:
    """A model service's prediction, raw units: times (T,), mean (T, D), std (T, D), latent (L,),
    samples (S, T, D) or None; the skill and the model version that answered."""

    skill: str
    version: int
    times: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    latent: np.ndarray
    samples: np.ndarray | None = None

    @classmethod
    def from_reply(cls, reply: dict) -> "PredictResult":
        """Build from one decoded predict reply map."""
        return cls(reply["skill"], reply["version"], reply["times"], reply["mean"], reply["std"],
                   reply["latent"], reply.get("samples"))


@dataclass(frozen=True)
class JobSummary:
    """One job as the learner lists it (docs/PROTOCOL.md, ``jobs``).

    job : id. kind : ``adapt`` or ``train_pair``. skill, task, robot : what it adapts and where.
    state : ``queued``, ``running``, ``interrupted``, ``done``, ``failed`` or ``cancelled``.
    rollouts : roll-outs used by the current (final) attempt (training steps for ``train_pair``),
    of ``budget``. rollouts_executed : roll-outs executed by all its attempts (what the recording
    holds of it; None from a learner that does not say). attempt : 0, +1 per restart.
    excluded_workers : the workers its current attempt excluded and why (docs/PROTOCOL.md). best_return :
    best return seen (None before the first). success : the result's (None until it finished).
    committed_version : the skill version holding its solution, if assimilated. created, updated :
    wall time (s since the epoch).
    """

    job: str
    kind: str
    skill: str
    task: str
    robot: str
    state: str
    rollouts: int
    budget: int | None
    best_return: float | None
    success: bool | None
    committed_version: int | None
    created: float
    updated: float
    rollouts_executed: int | None = None
    attempt: int | None = None
    excluded_workers: tuple[Exclusion, ...] = ()

    @classmethod
    def from_reply(cls, row: dict) -> "JobSummary":
        """Build from one row of a ``jobs`` reply (extra fields of a newer learner are ignored)."""
        values = {name: row.get(name) for name in cls.__dataclass_fields__}
        values["excluded_workers"] = tuple(Exclusion.from_dict(e) for e in row.get("excluded_workers") or ())
        return cls(**values)


def predict_request(obs_times, obs_values, task_params=None, query_times=None, *, n_steps: int | None = None,
                    obs_dims_mask=None, n_samples: int | None = None, seed: int | None = None) -> dict:
    """Build a predict request map (arrays as float64/bool numpy arrays; see docs/PROTOCOL.md).

    obs_times (N,), obs_values (N, D), task_params (P,) or None, query_times (T,) or ``n_steps``,
    obs_dims_mask (N, D) bool or None, ``n_samples`` with ``seed`` for sampled trajectories.
    ValueError when both ``query_times`` and ``n_steps`` are given (the model service refuses it).
    """
    if query_times is not None and n_steps is not None:
        raise ValueError("query_times and n_steps: give one of them (n_steps makes a uniform grid of "
                         "query times), not both")
    req: dict[str, Any] = {"v": 1, "obs_times": np.asarray(obs_times, dtype=np.float64).reshape(-1),
                           "obs_values": np.atleast_2d(np.asarray(obs_values, dtype=np.float64))}
    if task_params is not None:
        req["task_params"] = np.asarray(task_params, dtype=np.float64).reshape(-1)
    if query_times is not None:
        req["query_times"] = np.asarray(query_times, dtype=np.float64).reshape(-1)
    if n_steps is not None:
        req["n_steps"] = int(n_steps)
    if obs_dims_mask is not None:
        req["obs_dims_mask"] = np.asarray(obs_dims_mask, dtype=bool)
    if n_samples is not None:
        req["n_samples"] = int(n_samples)
    if seed is not None:
        req["seed"] = int(seed)
    return req


class ACNMPClient:
    """A zenoh session plus the request/reply plumbing of the ACNMP protocol.

    Parameters
    ----------
    namespace : deployment namespace (``acnmp/<namespace>/...``); None: the discovered one.
    connect : endpoints to connect to; default ``$ACNMP_CONNECT`` (comma-separated), else the
        running deployment found by its run file (clients/discovery.py :func:`resolve`).
    mode : zenoh mode of the client's own session, ``peer`` or ``client``; default: what the
        discovered deployment's config file says (``client`` of an authenticated one), else ``peer``.
    listen, config_file : passed to :func:`services.transport.session.open_session`.
    timeout : default seconds per query. role : credentials taken from a discovered secured
        deployment, ``operator`` (may start jobs) or ``client`` (queries only).

    ``authenticated`` says whether the client joined with a zenoh user and password (its config
    file names one), None when it was given its ``session``.

    Use as a context manager, or call :meth:`close`: an open session keeps the process from exiting.
    """

    def __init__(self, namespace: str | None = None, connect: Sequence[str] | None = None,
                 mode: str | None = None, listen: Sequence[str] | None = None, config_file: str | None = None,
                 timeout: float = 10.0, session: zenoh.Session | None = None, role: str = "operator"):
        self.timeout = float(timeout)
        self._stack = contextlib.ExitStack()
        self.authenticated: bool | None = None
        if session is None:
            target = resolve(namespace, connect, config_file, mode, role)
            namespace = target.namespace
            # a client-mode session waits for its router at most the query timeout
            session = self._stack.enter_context(open_session(target.mode, listen, target.connect, target.config_file,
                                                             open_timeout=self.timeout))
            self.authenticated = target.config_file is not None and \
                zenoh.Config.from_file(target.config_file).get_json("transport/auth/usrpwd/user") != "null"
        self.namespace = namespace or DEFAULT_NAMESPACE
        self.keys = Keyspace(self.namespace)
        self.session = session
        self._processes: dict[str, set[str]] = {}  # skill -> zids of the model processes serving it
        self._processes_changed = threading.Condition()
        self._watching = False
        # whose turn is next among a skill's processes: each client starts elsewhere (its own zid)
        self._turn = itertools.count(int(str(session.zid()), 16) % 65536)

    def close(self) -> None:
        """Close the session (if the client opened it)."""
        self._stack.close()

    def __enter__(self) -> "ACNMPClient":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ----- plumbing --------------------------------------------------------------------------
    def request(self, key: str, payload: dict | None = None, timeout: float | None = None) -> dict:
        """Send one query on ``key`` and return the decoded reply map (the first successful one when
        several services answer); raises :class:`ClientError`. See :func:`services.transport.rpc.call`."""
        return call_when_available(self.session, key, payload, self.timeout if timeout is None else float(timeout))

    # ----- model service ---------------------------------------------------------------------
    def model_processes(self, skill: str, at_least: int = 0, timeout: float = 10.0) -> list[str]:
        """The zenoh ids of the model processes serving ``skill``, as this client knows them (from a
        liveliness subscriber declared on the first call). With ``at_least``, wait until it knows that
        many (TimeoutError after ``timeout`` seconds); without, the first call may return []."""
        with self._processes_changed:
            if not self._watching:
                self._watching = True
                sub = self.session.liveliness().declare_subscriber(
                    self.keys.model_process_token("*", "*"), self._on_model_process, history=True)
                self._stack.callback(sub.undeclare)
            if not self._processes_changed.wait_for(lambda: len(self._processes.get(skill, ())) >= at_least,
                                                    timeout):
                raise TimeoutError(f"{len(self._processes.get(skill, ()))} model processes serve {skill!r} "
                                   f"after {timeout:g} s, not {at_least}")
            return sorted(self._processes.get(skill, ()))

    def _on_model_process(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        if not is_concrete(key):
            return
        skill, zid = key.split("/")[-2:]
        with self._processes_changed:
            zids = self._processes.setdefault(skill, set())
            if sample.kind == zenoh.SampleKind.PUT:
                zids.add(zid)
            else:
                zids.discard(zid)
            self._processes_changed.notify_all()

    def _predict_request(self, skill: str, payload: dict, timeout: float | None) -> dict:
        """A predict query: with several model processes serving ``skill``, sent to one of them in
        turn (each computes only what it is sent; on the skill's own key every process would compute
        it), else on the skill's key. A process gone meanwhile (``unavailable``) falls back to the
        skill's key."""
        processes = self.model_processes(skill)
        if len(processes) > 1:
            zid = processes[next(self._turn) % len(processes)]
            try:
                return call(self.session, self.keys.predict_at(skill, zid), payload,
                            self.timeout if timeout is None else float(timeout))
            except WireError as exc:
                if exc.code != "unavailable":
                    raise
        return self.request(self.keys.predict(skill), payload, timeout)

    def predict(self, skill: str, obs_times, obs_values, task_params=None, query_times=None, *,
                n_steps: int | None = None, obs_dims_mask=None, n_samples: int | None = None,
                seed: int | None = None, timeout: float | None = None) -> PredictResult:
        """Condition ``skill`` on observations (and task parameters) and predict a trajectory.

        obs_times (N,), obs_values (N, D), task_params (P,), query_times (T,) or ``n_steps`` (a
        uniform grid over the trained time range); ``obs_dims_mask`` (N, D) bool marks which
        dimensions each observation carries. Returns a :class:`PredictResult` (raw units).
        """
        req = predict_request(obs_times, obs_values, task_params, query_times, n_steps=n_steps,
                              obs_dims_mask=obs_dims_mask, n_samples=n_samples, seed=seed)
        return PredictResult.from_reply(self._predict_request(skill, req, timeout))

    def transfer(self, skill: str, obs_times, obs_values, query_times=None, *, n_steps: int | None = None,
                 obs_dims_mask=None, n_samples: int | None = None, seed: int | None = None,
                 timeout: float | None = None) -> PredictResult:
        """Robot B's trajectory for robot A's observations, from paired skill ``skill`` (A's encoder,
        B's decoder; docs/PROTOCOL.md ``skill/<skill>/transfer``).

        obs_times (N,), obs_values (N, D_A) robot A's raw units, query_times (T,) or ``n_steps``.
        Returns a :class:`PredictResult`: mean, std (T, D_B) robot B's raw units, latent (L,).
        """
        req = predict_request(obs_times, obs_values, None, query_times, n_steps=n_steps,
                              obs_dims_mask=obs_dims_mask, n_samples=n_samples, seed=seed)
        return PredictResult.from_reply(self.request(self.keys.transfer(skill), req, timeout))

    def predict_batch(self, skill: str, requests: Sequence[dict], timeout: float | None = None) -> list[PredictResult]:
        """Several predict requests (maps from :func:`predict_request`) in one query, answered by one
        model version. Returns one :class:`PredictResult` per request, in order."""
        reply = self._predict_request(skill, {"v": 1, "batch": list(requests)}, timeout)
        return [PredictResult.from_reply(r) for r in reply["results"]]

    def info(self, skill: str, timeout: float | None = None) -> dict:
        """The served model of ``skill``: dimensions, names, ranges, version, data hash, n_demos."""
        return self.request(self.keys.info(skill), None, timeout)

    def skills(self, timeout: float = 2.0) -> list[str]:
        """Names of the skills some model service has weights for now (liveliness tokens)."""
        return sorted({last_chunk(k) for k in alive_tokens(self.session, self.keys.model_token("*"), timeout)})

    def model_services(self, timeout: float = 2.0) -> int:
        """How many model services are live and reachable now (liveliness tokens), skills or not."""
        return len(alive_tokens(self.session, self.keys.model_service_token("*"), timeout))

    # ----- learner ---------------------------------------------------------------------------
    def train(self, skill: str, times, values, task_params=None, timeout: float | None = None, **options) -> dict:
        """Ask the learner to train ``skill`` on demonstrations and wait until it has.

        times (N, T) or (T,), values (N, T, D), task_params (N, P) or None; ``options`` are extra
        request fields passed as they are (``train``: TrainConfig overrides, ``model``: CNMPConfig
        overrides, ``seed``, ``value_names``, ``task_param_names``). Returns the learner's reply:
        ``{"skill", "version", "data_hash", "n_demos"}``.
        """
        req: dict[str, Any] = {"v": 1, "times": np.asarray(times, dtype=np.float64),
                               "values": np.asarray(values, dtype=np.float64), **options}
        if task_params is not None:
            req["task_params"] = np.asarray(task_params, dtype=np.float64)
        return self.request(self.keys.train(skill), req, timeout)

    def adapt(self, skill: str, job: AdaptJob, timeout: float | None = None) -> str:
        """Queue adaptation ``job`` (:class:`~acnmp_core.jobs.adapt.AdaptJob`) on ``skill``; returns the
        job id. The request is ``job.to_dict()`` (docs/PROTOCOL.md, ``skill/<skill>/adapt``)."""
        return self._job(self.request(self.keys.adapt(skill), {"v": 1, **job.to_dict()}, timeout))

    def train_pair(self, skill: str, job: PairTrainJob, timeout: float | None = None) -> str:
        """Queue the training of paired skill ``skill`` (:class:`~acnmp_core.jobs.transfer.PairTrainJob`:
        two robots' paired demonstrations, a TransferConfig, a seed) on the learner; returns the job
        id (follow it with :meth:`wait_job`; its status' ``committed_version`` is the new version)."""
        return self._job(self.request(self.keys.train_pair(skill), {"v": 1, **job.to_dict()}, timeout))

    def weights(self, skill: str, timeout: float | None = None):
        """The learner's newest weights of ``skill``, rebuilt and checked
        (:class:`services.model.weights.ModelWeights`: ``model``, and ``partner`` for a paired skill)."""
        from services.model.weights import parse_weights

        return parse_weights(self.request(self.keys.weights_latest(skill), None, timeout))

    @staticmethod
    def _job(reply: dict) -> str:
        job = reply.get("job")
        if not isinstance(job, str):
            raise ClientError("internal", f"learner reply has no job id: {sorted(reply)}")
        return job

    def job_status(self, job: str, timeout: float | None = None) -> dict:
        """The learner's status map of ``job`` (state, iteration, rollouts, ...)."""
        return self.request(self.keys.job_status(job), None, timeout)

    def jobs(self, limit: int = 100, timeout: float | None = None) -> list[JobSummary]:
        """The deployment's newest ``limit`` (1..1000) jobs, newest first (by ``created``). With
        several learners each answers for the jobs of its own skills; the answers of all that are
        live are merged: asked again, until ``timeout``, while a learner that a reply names live has
        not answered, or fewer answered than there are live learner tokens (a fresh session may not
        know every learner's queryable, nor every token, yet)."""
        timeout = self.timeout if timeout is None else float(timeout)
        deadline = time.monotonic() + timeout
        while True:
            replies = call_when_available(self.session, self.keys.jobs(), {"v": 1, "limit": int(limit)},
                                          max(deadline - time.monotonic(), 0.05), caller=call_all)
            remaining = deadline - time.monotonic()
            answered = {reply.get("learner") for reply in replies}
            named = {lid for reply in replies for lid in reply.get("live", ())}
            if remaining <= 0 or (named <= answered and len(replies) >= len(
                    alive_tokens(self.session, self.keys.learner_token("*"), min(remaining, 2.0)))):
                break
            time.sleep(0.1)
        rows = [JobSummary.from_reply(row) for reply in replies for row in reply["jobs"]]
        return sorted(rows, key=lambda r: r.created, reverse=True)[:limit]

    def cancel(self, job: str, timeout: float | None = None) -> dict:
        """Cancel ``job`` on the learner; returns its status map afterwards: ``cancelled`` for a job
        that was queued, ``running`` with ``cancel_requested`` for one that stops after its current
        iteration, its final state for a finished one. ClientError ``unknown_job`` if there is none."""
        return self.request(self.keys.job_cancel(job), None, timeout)

    def wait_job(self, job: str, timeout: float = 600.0, *, poll: float = 0.5, progress: bool = True,
                 on_status: Callable[[dict], None] | None = None) -> dict:
        """Poll ``job`` until it is done, failed or cancelled; return its last status map.

        With ``progress`` a tqdm bar shows roll-outs used (out of the budget when the status has
        one); ``on_status`` is called with every status polled. While no learner answers (``unavailable``/``timeout``: it is restarting, say) polling
        goes on: the restarted learner resumes the job from its checkpoint and answers again.
        Raises ClientError ``timeout`` after ``timeout`` seconds.
        """
        bar = None
        deadline = time.monotonic() + timeout
        try:
            while True:
                try:
                    status = self.job_status(job)
                except ClientError as exc:
                    if exc.code not in RETRY_CODES or time.monotonic() > deadline:
                        raise
                    time.sleep(poll)
                    continue
                if progress:
                    bar = _update_bar(bar, job, status)
                if on_status is not None:
                    on_status(status)
                if status.get("state") in TERMINAL_JOB_STATES:
                    return status
                if time.monotonic() > deadline:
                    raise ClientError("timeout", f"job {job} not finished after {timeout}s (state {status.get('state')!r})")
                time.sleep(poll)
        finally:
            if bar is not None:
                bar.close()


def _update_bar(bar, job: str, status: dict):
    """Create or advance a tqdm bar from a job status (roll-outs, out of ``budget`` if known)."""
    from tqdm import tqdm

    total = status.get("budget") if isinstance(status.get("budget"), int) else None
    if bar is None:
        bar = tqdm(total=total, desc=f"job {job}", unit="rollout")
    done = status.get("rollouts")
    if isinstance(done, int) and done > bar.n:
        bar.update(done - bar.n)
    best = status.get("best_return")
    bar.set_postfix(state=status.get("state"), best=None if best is None else f"{best:.3g}", refresh=True)
    return bar
