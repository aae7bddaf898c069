"""The paper's experiments run across a local deployment (``acnmp experiment ... --distributed``).

An application above the services: it starts a deployment (services/launcher), talks to it as a
client (:class:`~clients.client.ACNMPClient`) and publishes roll-outs for the recorder.

E2 and E3 drive their loops in this process and only execute roll-outs remotely:
:func:`remote_rollouts` starts workers (and a recorder) and hands out evaluators that send the
roll-outs to the workers and publish each one for the recording.

E1 runs as a client of the services (of a fresh deployment, or of the running one
``acnmp experiment viapoint --distributed`` found by its run file): the learner trains the skill from the demonstrations
(unless its current version is already what that training gives: then the run uses it as it is) and runs
one adaptation job per method, the jobs' roll-outs go to the workers, the recorder logs every one,
and the assimilated model is read back through the model service. The learner calls the same
library functions with the same seeds as :func:`acnmp_core.experiments.viapoint.run_viapoint`,
so the numbers are the same as in one process.

Fail-over: the deployment restarts a child that dies (services/launcher/supervision.py). While a
service is away its queries answer ``unavailable`` (or ``timeout``); :class:`DeployedSkill` then
waits and asks again (up to ``patience`` seconds per request) instead of failing: a restarted
learner resumes the job from its checkpoint (same seed, so the same result) and
:meth:`~clients.client.ACNMPClient.wait_job` re-attaches to it by polling its status; a restarted
model service loads the learner's latest weights. A train request is sent again (same seed: the
same model, perhaps under the next version number).
"""
from __future__ import annotations

import itertools
import os
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from typing import Callable, Iterator, TypeVar

import numpy as np
import zenoh

from acnmp_core.adaptation.config import AdaptResult
from acnmp_core.experiments.recipe import PAPER, Recipe
from acnmp_core.experiments.viapoint import ViaPointRun, ViaPointSetup, run_viapoint
from acnmp_core.jobs.adapt import AdaptJob, result_from_dict
from clients.client import RETRY_CODES, ACNMPClient, ClientError
from services.launcher import LocalDeployment
from services.recording.publisher import EventPublisher
from services.recording.recorded import RecordedEvaluator
from services.transport import Keyspace, alive_tokens
from services.worker.remote import RemoteEvaluator

SKILL = "e1"
#: Seconds one request may wait for its service to come back (a restart takes a few seconds).
PATIENCE = 120.0

T = TypeVar("T")


def patiently(send: Callable[[], T], what: str, patience: float = PATIENCE, *, progress: bool = False) -> T:
    """``send()``, sent again while it fails with ``unavailable``/``timeout`` (the service is being
    restarted), for up to ``patience`` seconds; other errors, and the last one, are raised."""
    deadline = time.monotonic() + patience
    while True:
        try:
            return send()
        except ClientError as exc:
            if exc.code not in RETRY_CODES or time.monotonic() > deadline:
                raise
            if progress:
                print(f"{what}: {exc.code}; waiting for the service to come back", flush=True)
            time.sleep(0.5)


def experiment_deployment(prefix: str, *, secure: bool = True, **kwargs) -> LocalDeployment:
    """The (not yet started) deployment of one experiment run: namespace ``<prefix>-<pid>``,
    ``kwargs`` for :class:`~services.launcher.LocalDeployment` (workers, robot, record, model,
    learner). ``secure`` (default): authenticated as ``acnmp up`` is (zenoh user/password on
    every link, the router's ACL), its generated secrets in its state directory, no run file
    (it is private to this run); ``secure=False`` is ``--insecure``, the open peer mesh.
    The experiment talks to it through the launcher's own session (``dep.session``)."""
    return LocalDeployment(f"{prefix}-{os.getpid()}", secure=secure, announce=False, **kwargs)


@dataclass(frozen=True)
class DeploymentFacts:
    """What an experiment run with ``--distributed`` records of the deployment it ran on (the
    ``deployment`` of its JSON).

    namespace : the deployment's. attached : a running deployment it joined (``--namespace``, or
    found by its run file) rather than one started for the run. workers : the experiment robot's
    workers when the run began. recording : the file the deployment's recorder writes, None when
    nothing records the run. authenticated : whether it is joined with a user and password only.
    """

    namespace: str
    attached: bool
    workers: int
    recording: str | None
    authenticated: bool

    def to_dict(self) -> dict:
        """The JSON map."""
        return asdict(self)


def started_facts(dep: LocalDeployment, workers: int, record: str | None) -> DeploymentFacts:
    """The facts of a deployment started for the run (``workers`` of its robot, ``record``)."""
    return DeploymentFacts(dep.namespace, False, int(workers), str(record) if record else None, bool(dep.secure))


def joined_facts(client: ACNMPClient, robot: str, workers: int | None = None, discover: float = 2.0) -> DeploymentFacts:
    """The facts of the running deployment ``client`` joined: its live ``robot`` workers (``workers``
    when already counted, else looked for up to ``discover`` seconds) and its recorder's file (asked
    of the recorder once; None without one, or when it does not answer within 5 s: the file is a
    fact for the run's JSON, not a reason to hold the run up while the recorder is unreachable)."""
    if workers is None:
        workers = len(alive_tokens(client.session, client.keys.worker_token(robot), discover))
    recording = None
    if alive_tokens(client.session, client.keys.tokens("recorder"), discover):
        try:
            recording = client.request(client.keys.recorder_status(), None, 5.0)["path"]
        except ClientError:
            recording = None
    return DeploymentFacts(client.namespace, True, workers, recording, bool(client.authenticated))


@contextmanager
def remote_rollouts(robot: str, task: str, *, workers: int = 2, record: str | None = None,
                    prefix: str = "exp", progress: bool = True, secure: bool = True,
                    namespace: str | None = None, config: str | None = None) -> Iterator[EvaluatorMaker]:
    """Start ``workers`` workers of ``robot`` (and a recorder writing ``record`` when given) on a
    fresh local deployment (authenticated unless ``secure`` is False, :func:`experiment_deployment`),
    or, with ``namespace``, join the running deployment of that name (:func:`attach`, through the
    zenoh ``config`` file when given: its
    ``robot`` workers, its recorder if it has one); yield ``make(job, task_config=None, extra=None)``,
    which returns an evaluator that executes roll-outs of ``task`` on those workers (with
    fail-over) and, when recording, publishes every roll-out under the job name ``<job>-<n>`` (n
    counts the evaluators made, so repeated runs of one method never share roll-out indices), with
    the fields ``extra`` added to each event (an :class:`EvaluatorMaker`; its ``deployment`` is
    what the run's JSON records). A fresh deployment stops when the block exits."""
    if namespace is not None:
        with attach(namespace, robot, record=record, secure=secure, progress=progress, config=config) as joined:
            yield EvaluatorMaker(joined, robot, task, joined.facts, record=joined.events is not None)
        return
    with experiment_deployment(prefix, secure=secure, workers=workers, robot=robot, record=record,
                               model=False, learner=False) as dep:
        if progress:
            print(dep.describe(), flush=True)
        yield EvaluatorMaker(dep, robot, task, started_facts(dep, workers, record), record=bool(record))


@dataclass
class Attached:
    """A running deployment this process joined as its operator (``--namespace``): the client and
    its session, the event publisher when the deployment has a recorder, and its facts."""

    namespace: str
    client: ACNMPClient
    events: EventPublisher | None
    facts: DeploymentFacts

    @property
    def session(self) -> zenoh.Session:
        return self.client.session

    @property
    def keys(self) -> Keyspace:
        return self.client.keys


@contextmanager
def attach(namespace: str, robot: str, *, record: str | None = None, secure: bool = True,
           progress: bool = True, discover: float = 10.0, config: str | None = None) -> Iterator[Attached]:
    """Join the running deployment ``namespace`` with the operator's credentials
    (:func:`operator_client`), for an experiment's roll-outs on its ``robot`` workers.

    ValueError, naming ``--namespace``, when no such deployment runs or it has no ``robot`` worker
    (looked for up to ``discover`` seconds); also for ``record`` (its own recorder records, if it
    has one) and ``secure=False`` (it keeps its own authentication). When it has no recorder, the
    roll-outs run unrecorded and a line says so. Waits at exit until its recorder confirmed them.
    """
    if record:
        raise ValueError(f"--record: with --namespace {namespace}, the deployment's own recorder records "
                         "(`acnmp up --record`); drop one of them")
    if not secure:
        raise ValueError(f"--insecure: deployment {namespace!r} keeps its own authentication; drop --insecure")
    with operator_client(namespace, config) as client:
        deadline = time.monotonic() + discover
        while not (workers := alive_tokens(client.session, client.keys.worker_token(robot), 2.0)):
            if time.monotonic() > deadline:
                raise ValueError(f"--namespace {namespace}: the deployment runs no {robot} workers "
                                 f"(start one with `acnmp up --robot {robot}`)")
        events = None
        if alive_tokens(client.session, client.keys.tokens("recorder"), 2.0):
            events = EventPublisher(client.session, client.keys)
        if progress:
            print(f"running on deployment {client.namespace!r} ({len(workers)} {robot} worker(s)); roll-outs "
                  + ("recorded by its recorder" if events else "not recorded: it runs no recorder"), flush=True)
        facts = joined_facts(client, robot, workers=len(workers))
        try:
            yield Attached(client.namespace, client, events, facts)
        finally:
            if events is not None:
                if not events.wait_recorded(30.0):
                    print(f"deployment {client.namespace!r}: its recorder did not confirm every roll-out", flush=True)
                events.close()


def operator_client(namespace: str, config: str | None = None, timeout: float = 30.0) -> ACNMPClient:
    """An operator's client of the running deployment ``namespace``: through the zenoh ``config``
    file when given (``acnmp credentials``' ``operator.json5``: a deployment on other hosts, whose
    router that file connects to), else found by its run file on this machine (``acnmp up``).
    ValueError naming the option when there is no such deployment or its router cannot be reached."""
    from services.transport.runfile import DeploymentNotFound, find

    if config is not None:
        try:
            return ACNMPClient(namespace, config_file=config, role="operator", timeout=timeout)
        except ConnectionError as exc:
            raise ValueError(f"--config {config}: {exc}") from None
    try:
        run = find(namespace)
    except DeploymentNotFound:
        raise ValueError(f"--namespace {namespace}: no such deployment is running (`acnmp status` lists them)") from None
    return ACNMPClient(run.namespace, role="operator", timeout=timeout)


class EvaluatorMaker:
    """``make(job, task_config=None, extra=None, *, method=, seed=)`` for a started deployment ``dep``
    (or one joined, :class:`Attached`): an evaluator that executes roll-outs of ``task`` on its
    ``robot`` workers (with fail-over) and, with ``record``, publishes a ``job`` event (the method,
    task, its configuration and seed) and every roll-out under the job name ``<job>-<n>`` (n counts
    the evaluators made) with the fields ``extra`` added to each event. ``deployment`` holds the
    facts the run's JSON records. RuntimeError if its recorder is not up."""

    def __init__(self, dep: LocalDeployment | Attached, robot: str, task: str, deployment: DeploymentFacts, *,
                 record: bool) -> None:
        self.dep, self.robot, self.task, self.deployment = dep, robot, task, deployment
        self.publisher = None
        if record:
            self.publisher = dep.events  # the deployment's: its stop() waits until the recorder has what it published
            if self.publisher is None or not self.publisher.wait_for_recorder(timeout=30):
                raise RuntimeError(f"the recorder of deployment {dep.namespace!r} did not come up")
        self.counter = itertools.count()

    def __call__(self, job: str, task_config: dict | None = None, extra: dict | None = None, *,
                 method: str = "unknown", seed: int | None = None):
        remote = RemoteEvaluator(self.dep.session, self.dep.keys, self.robot, self.task, task_config)
        if self.publisher is None:
            return remote
        about = {"method": method, "task": self.task, "seed": seed, "task_config": task_config or {}}
        return RecordedEvaluator(remote, self.publisher, f"{job}-{next(self.counter)}", self.robot, extra, about=about)


class DeployedSkill:
    """E1's skill served by a deployment: the learner trains it and runs the adaptation jobs (its
    roll-outs on the workers), the model service answers the predictions. A
    :class:`~acnmp_core.experiments.viapoint.SkillBackend`, so the measurements are those of
    the in-process run, made by the same code."""

    def __init__(self, client: ACNMPClient, progress: bool = True) -> None:
        self.client, self.progress = client, progress
        self.jobs: dict[str, str] = {}
        #: the skill's version the run started from, and whether the learner trained it for the run
        #: (False: the deployment's skill was already what this training gives, and was reused)
        self.skill: dict | None = None

    def train(self, demos, steps: int, seed: int, prior: str = "none") -> dict:
        arrays = np.stack([d.values for d in demos])
        # the run's recipe says the model: the paper's CNMP has no linear path ("none"), the default
        # chooses it at training ("auto"); said explicitly, whatever the deployment's default skill is
        reply = patiently(lambda: self.client.train(SKILL, demos[0].times, arrays, train={"steps": steps},
                                                    model={"prior": prior}, seed=seed, reuse=True, timeout=600),
                          "train", progress=self.progress)
        self.skill = {"name": SKILL, "version": int(reply["version"]), "trained": bool(reply.get("trained", True))}
        self._wait_version(reply["version"])
        config = self.client.info(SKILL)["config"]  # the model service's: the prior it chose, and why
        choice = config.get("prior_choice")
        return {"prior": config["prior"], "errors": None if choice is None else choice["errors"],
                "reason": None if choice is None else choice["reason"]}

    def predict(self, obs_times, obs_values, task_params, query_times):
        return patiently(lambda: self.client.predict(SKILL, obs_times, obs_values, task_params, query_times,
                                                     timeout=30), "predict", progress=self.progress)

    def adapt(self, setup: ViaPointSetup, method: str, cfg, seed: int, assimilation) -> AdaptResult:
        job = AdaptJob(setup.target, "viapoint", "point2d", setup.task_config, cfg, seed=seed,
                       commit=assimilation is not None,
                       **({} if assimilation is None else {"assimilate_steps": assimilation.steps}))
        job_id = patiently(lambda: self.client.adapt(SKILL, job), "adapt", progress=self.progress)
        self.jobs[method] = job_id
        status = self.client.wait_job(job_id, timeout=1800, progress=self.progress)
        if status["state"] != "done":
            raise RuntimeError(f"job {job_id} ({method}) ended {status['state']}: {status.get('error')}")
        if status.get("committed_version") is not None:
            self._wait_version(int(status["committed_version"]))
        return result_from_dict(status["result"])

    def _wait_version(self, version: int, timeout: float = 60.0) -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            try:
                if self.client.info(SKILL)["version"] >= version:
                    return
            except Exception:  # the model service may not have the skill yet
                pass
            time.sleep(0.2)
        raise TimeoutError(f"the model service did not serve version {version} of {SKILL!r} in {timeout:.0f} s")


@contextmanager
def e1_deployment(*, workers: int = 2, record: str | None = None, secure: bool = True, progress: bool = True,
                  client: ACNMPClient | None = None) -> Iterator[tuple[ACNMPClient, DeploymentFacts]]:
    """E1's deployment: a fresh local one (``workers`` point-mass workers, a recorder writing
    ``record`` when given; authenticated unless ``secure`` is False, :func:`experiment_deployment`),
    stopped at the end, or with ``client`` the running one it is connected to (``acnmp up``: its
    learner, model service and point2d workers). Yields the client and the deployment's facts."""
    if client is not None:
        yield client, joined_facts(client, "point2d")
        return
    with experiment_deployment("e1", secure=secure, workers=workers, robot="point2d", record=record) as dep, \
            ACNMPClient(dep.namespace, session=dep.session, timeout=30) as own:
        if progress:
            print(dep.describe(), flush=True)
        yield own, started_facts(dep, workers, record)


def run_viapoint_on(client: ACNMPClient, facts: DeploymentFacts, seed: int = 0, variant: str = "2d", *,
                    budget: int = 100, train_steps: int = 3000, progress: bool = True,
                    adapt_overrides: dict | None = None, recipe: Recipe = PAPER) -> ViaPointRun:
    """Run E1 on the deployment ``client`` reaches (:func:`e1_deployment`). Returns a
    :class:`ViaPointRun` like the in-process run, its summary with the ``deployment``'s ``facts``,
    the ``skill`` the run started from (its version, and ``trained``: False when the deployment's
    skill was already what this run's training gives and was used as it was) and each method's
    job id; ``recipe`` the method (the paper's, or the product's default: the model's prior and the
    adaptation settings, :mod:`acnmp_core.experiments.recipe`)."""
    skill = DeployedSkill(client, progress=False)
    run = run_viapoint(seed, variant, budget=budget, train_steps=train_steps, backend=skill,
                       progress=progress, adapt_overrides=adapt_overrides, recipe=recipe)
    run.summary.update(deployment=facts.to_dict(), skill=skill.skill)
    for method, job in skill.jobs.items():
        run.summary["methods"][method]["job"] = job
    return run


def run_viapoint_distributed(seed: int = 0, variant: str = "2d", *, budget: int = 100, train_steps: int = 3000,
                             workers: int = 2, record: str | None = None, progress: bool = True,
                             adapt_overrides: dict | None = None, client: ACNMPClient | None = None,
                             secure: bool = True) -> ViaPointRun:
    """:func:`run_viapoint_on` one seed on :func:`e1_deployment` (a fresh one, or ``client``'s)."""
    with e1_deployment(workers=workers, record=record, secure=secure, progress=progress, client=client) as (c, facts):
        return run_viapoint_on(c, facts, seed, variant, budget=budget, train_steps=train_steps, progress=progress,
                               adapt_overrides=adapt_overrides)
