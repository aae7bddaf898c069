"""Start a whole deployment on one machine: recorder, learner, model service and N workers.

:class:`LocalDeployment` (a context manager) is what ``acnmp up``, the tests and
``acnmp experiment ... --distributed`` use:

1. it opens its own peer session listening on the **anchor** ``tcp/127.0.0.1:<free port>``
   (multicast scouting off; services/transport/session.py explains the gossip mesh that follows);
2. it starts each child as ``python -m services.<wing> --connect <anchor> --namespace NS``, each
   in its own session so a terminal's Ctrl-C reaches only the launcher, which then stops the
   children in order, once each; the recorder is started and awaited first, so no event is lost.
   The learners, model processes and workers are forked by a spawner that imported their modules
   (torch) once, before any zenoh session exists (services/launcher/spawner.py; one for all the
   deployments of a process with :func:`share_spawner`); the recorder, and any child whose
   environment differs from the spawner's (but for ``PER_CHILD_ENV``), is a fresh interpreter;
3. it waits until every child's liveliness token is seen (a child that exits first is reported
   as :class:`ChildExited`, whose first line carries the child's last error line), then reports
   each problem a live process states (a learner's quarantined files) through ``report``;
4. on exit it sends SIGTERM to the learner, the model and the workers at once (the learner's
   running job abandons its batch in flight and is saved ``interrupted``), then, once the learner
   has exited, to the recorder (so it records the last events and writes its footer); a child
   still alive after ``stop_timeout`` seconds is SIGKILLed; then it closes its session.

A recording is never rewritten (services/recording/segments.py): when ``record`` already holds a
recording (an earlier session's, or one whose launcher was killed), the recorder writes its next
segment ``<name>.<n>.rrd`` under the same Rerun application and recording id, given the earlier
segments (``--seen``) so that what they hold (a learner's journalled roll-outs published again)
is not written twice; ``acnmp replay <name>.rrd`` reads the segments together. A file there that
is not an ACNMP recording is refused (ValueError) before anything starts.

While it runs, a :class:`~services.launcher.supervision.Supervisor` restarts a child that dies
(backoff, a restart limit; each restart logged and published as a ``process`` event); a
restarted recorder writes the next segment (``recordings``: this session's files), since the dead
one's file cannot be reopened; ``stop()`` merges this session's files into its first one
(``rerun rrd merge``: one file that verifies) and removes the merged recorders' marks files
(``<file>.seen.json``; the first file's stays, for the session that continues the recording). The
restarted recorder recovers the events published while no recorder ran from the publishers'
caches and is given the earlier files (``--seen``) so it records none twice
(services/recording/recorder.py).
``stop()`` ends supervision before it stops anything.

The state directory is locked (``<state_dir>/deployment.lock``) while the deployment runs, so a
second deployment on it refuses to start; the learner locks it too (``learner.lock``).

Children's output goes to ``<log_dir>/<name>.log``.
"""
from __future__ import annotations

import contextlib
import logging
import os
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Sequence

import zenoh

from acnmp_core.robots.registry import PLUGINS_ENV, plugins_for_children
from acnmp_core.robots.registry import robot as robot_spec
from services.learner.ownership import learner_argv, numbered_ids, state_dir_of
from services.recording.event_ids import marks_path
from services.recording.segments import next_segment, recording_identity, recording_segments
from services.recording.publisher import EventPublisher
from services.recording.web_viewer import page_url
from services.transport import Keyspace, free_port, loopback_endpoint, open_session, wait_for_liveliness
from services.transport.about import list_processes
from services.transport.lifetime import PARENT_PID_ENV
from services.transport.state_dir import DirectoryLock

from .announce import Announcement, check_namespace_free
from .processes import entry_module
from .spawner import FORK_SERVER_AVAILABLE, FORKABLE, SpawnedProcess, Spawner, SpawnerGone
from .supervision import RestartPolicy, Supervisor

ROOT = Path(__file__).resolve().parents[2]
log = logging.getLogger(__name__)


class ChildExited(RuntimeError):
    """A child process exited before going live. Its first line names the child, its exit code,
    its last error line (from its log) and the log: ``learner exited with code 2 before going
    live: acnmp serve learner: error: ... (log STATE/logs/learner.log)``; the log's tail follows
    on the next lines. ``name``, ``code``, ``log`` and ``error`` (the last error line) are kept."""

    def __init__(self, name: str, code: int, log: Path | None):
        self.name, self.code, self.log = name, code, log
        self.error = last_error_line(log)
        super().__init__(f"{name} exited with code {code} before going live: {self.error or 'its log says nothing'} "
                         f"(log {log})\n{log_tail(log)}")


@dataclass
class Child:
    """One started process: its name, argv, Popen, the liveliness key expression(s) it declares,
    the query keys it serves (for the printed table) and its log file."""

    name: str
    argv: list[str]
    proc: subprocess.Popen | SpawnedProcess
    token: str
    serves: list[str] = field(default_factory=list)
    log: Path | None = None

    @property
    def pid(self) -> int:
        return self.proc.pid


class LocalDeployment:
    """A local deployment as a context manager: ``with LocalDeployment("ns", workers=2) as dep: ...``.

    Parameters
    ----------
    namespace : key prefix of this deployment. workers : number of workers of kind ``robot``.
    record : .rrd file for a recorder (None: no recorder). state_dir : learner checkpoints
        (None: a temporary directory, removed at exit). model : start the model service (it serves
        every skill the learner publishes). model_processes : how many model service processes
        (``model``, ``model-2``, ...); clients share their predicts between them
        (:meth:`clients.client.ACNMPClient.model_processes`). learner : start the learner.
    worker_delay : seconds per roll-out each worker sleeps (simulates a slow robot; tests).
    chunk_timeout : the learner's per-chunk worker timeout. start_timeout, stop_timeout : seconds.
    log_dir : children's logs (default: ``<state_dir>/logs``).
    secure : authenticated deployment (``acnmp up``, ``acnmp experiment ... --distributed``): the
        anchor is a zenoh router requiring a per-deployment password per role and applying the ACL
        of services/transport/auth.py, every child is its client (services/launcher/announce.py).
    announce : write a run file so clients find the deployment (``acnmp up``), its secrets beside
        it in the runtime directory; None (default): when ``secure``. A secured deployment not
        announced (``announce=False``: an experiment's private deployment) keeps its secrets in
        ``<state_dir>/secrets`` (mode 0700, removed at stop) and writes no run file.
    supervise : restart children that die (``restart_policy``, default :class:`RestartPolicy`);
        ``report(line)`` gets a line per restart (default: the log).
    fork_server : fork the learners, model processes and workers from a spawner that imported
        torch once (services/launcher/spawner.py; the process's kept one with
        :func:`share_spawner`); False: every child is a fresh interpreter.

    Attributes once started: ``session`` (the launcher's open session, usable by clients),
    ``anchor`` (endpoint to ``--connect`` to), ``children`` ({name: Child}), ``supervisor``
    (None without supervision), ``recordings`` (the recorder's files, first one first),
    ``viewer_url`` and ``web_viewer_url`` (with ``viewer``: the recorder also streams live over
    Rerun's gRPC server and hosts the web viewer, both on 127.0.0.1).
    """

    def __init__(self, namespace: str = "default", workers: int = 2, robot: str = "point2d",
                 record: str | os.PathLike | None = None, state_dir: str | os.PathLike | None = None, *,
                 model: bool = True, learner: bool = True, worker_delay: float = 0.0, chunk_timeout: float = 60.0,
                 start_timeout: float = 60.0, stop_timeout: float = 8.0, log_dir: str | os.PathLike | None = None,
                 learner_args: Sequence[str] = (), secure: bool = False, announce: bool | None = None,
                 supervise: bool = True, restart_policy: RestartPolicy | None = None,
                 report: Callable[[str], None] | None = None, viewer: bool = False, model_processes: int = 1,
                 learners: int = 1, fork_server: bool = True):
        self.robot = robot_spec(robot).kind  # UnknownRobotError (a ValueError) for a kind not registered
        if workers < 0:
            raise ValueError(f"workers: expected >= 0, got {workers}")
        self.keys = Keyspace(namespace)
        self.namespace = namespace
        self.n_workers = int(workers)
        self.record = None if record is None else Path(record).resolve()  # children run in ROOT
        if viewer and record is None:
            raise ValueError("viewer: the live viewer shows what the recorder records; give record too")
        self.viewer = viewer
        self.viewer_url: str | None = None  # rerun --connect takes it, once started with viewer=True
        self.web_viewer_url: str | None = None
        self._tmp = None
        if state_dir is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="acnmp-state-")
            state_dir = self._tmp.name
        self.state_dir = Path(state_dir).resolve()
        self.log_dir = Path(log_dir) if log_dir is not None else self.state_dir / "logs"
        self.with_model, self.with_learner = model, learner
        if model_processes < 1:
            raise ValueError(f"model_processes: expected >= 1, got {model_processes}")
        self.model_processes = int(model_processes)
        #: the learners' ids (and child names): ``learner``, ``learner-2``, ...
        self.learner_ids = numbered_ids(learners)
        self.worker_delay, self.chunk_timeout = float(worker_delay), float(chunk_timeout)
        self.start_timeout, self.stop_timeout = float(start_timeout), float(stop_timeout)
        self.learner_args = list(learner_args)
        self.children: dict[str, Child] = {}
        self._children_lock = threading.RLock()  # the supervisor replaces children from its thread
        self.supervise, self.restart_policy = bool(supervise), restart_policy or RestartPolicy()
        self.report = report
        self.supervisor: Supervisor | None = None
        self._events: EventPublisher | None = None
        self.recordings: list[Path] = [] if self.record is None else [self.record]  # this session's files
        #: the recording's files of earlier sessions, which this one continues (set by start())
        self.continued: list[Path] = []
        self.recording_id = uuid.uuid4().hex  # kept by a restarted recorder
        self._dir_lock = DirectoryLock(self.state_dir, "deployment.lock", "deployment")
        self.killed: list[str] = []  # children that needed SIGKILL when stopping
        self.session: zenoh.Session | None = None
        self.anchor = ""
        self._stack = contextlib.ExitStack()
        self.fork_server = bool(fork_server)
        self._spawner: Spawner | None = None
        self._owns_spawner = False  # a kept spawner (share_spawner) outlives the deployment
        self.secure = bool(secure)
        announce = self.secure if announce is None else bool(announce)
        self.announcement = (Announcement(namespace, self.secure, None if announce else self.state_dir / "secrets")
                             if self.secure or announce else None)

    # ----- starting --------------------------------------------------------------------------
    def _spawn(self, name: str, module: str, args: Sequence[str], token: str, serves: Sequence[str] = ()) -> Child:
        self.log_dir.mkdir(parents=True, exist_ok=True)
        log = self.log_dir / f"{name}.log"
        argv = [sys.executable, "-m", module, "--namespace", self.namespace, "--connect", self.anchor, *args]
        if self.announcement is not None:
            argv += self.announcement.child_args(name)
        proc = self._start_process(argv, log)
        child = Child(name, argv, proc, token, list(serves), log)
        with self._children_lock:
            self.children[name] = child
        return child

    def _start_process(self, argv: list[str], log_file: Path) -> subprocess.Popen | SpawnedProcess:
        """Start ``argv`` with its output appended to ``log_file``: forked by the spawner when it can
        (services/launcher/spawner.py), else as a fresh interpreter (:func:`_popen`)."""
        env = child_env()
        if self._spawner is not None and self._spawner.usable_for(argv, env):
            try:
                return self._spawner.spawn(argv, log_file, env)
            except SpawnerGone as exc:
                log.warning("%s; starting %s as a new interpreter", exc, argv[2])
        return _popen(argv, log_file, env)

    def _start_spawner(self) -> None:
        """Start the spawner for the learners, model processes and workers this deployment runs."""
        modules = [entry_module(name) for name, wanted in (("learner", self.with_learner),
                                                          ("model", self.with_model),
                                                          ("worker", self.n_workers > 0)) if wanted]
        if self.fork_server and modules and FORK_SERVER_AVAILABLE:
            env = child_env()
            self._spawner = _kept_spawner(env)
            self._owns_spawner = self._spawner is None
            if self._spawner is None:
                self.log_dir.mkdir(parents=True, exist_ok=True)
                self._spawner = Spawner(modules, env, ROOT, self.log_dir / "spawner.log")

    def _wait_live(self, children: Sequence[Child]) -> None:
        deadline = time.monotonic() + self.start_timeout
        for child in children:
            while True:
                if child.proc.poll() is not None:
                    raise ChildExited(child.name, child.proc.returncode, child.log)
                try:
                    wait_for_liveliness(self.session, child.token, timeout=0.5)
                    break
                except TimeoutError:
                    if time.monotonic() > deadline:
                        raise TimeoutError(f"{child.name} not live after {self.start_timeout}s; "
                                           f"log {child.log}:\n{log_tail(child.log)}") from None

    def start_worker(self, worker_id: str, *, robot: str | None = None, delay: float | None = None,
                     wait: bool = True) -> Child:
        """Start one more worker process (``robot`` defaults to the deployment's); returns its Child."""
        robot = robot or self.robot
        args = ["--robot", robot, "--id", worker_id, "--delay", str(self.worker_delay if delay is None else delay)]
        child = self._spawn(f"worker-{worker_id}", entry_module("worker"), args,
                            self.keys.worker_token(robot, worker_id), [self.keys.worker_rollout(robot, worker_id)])
        if wait:
            self._wait_live([child])
        return child

    def start(self) -> "LocalDeployment":
        """Lock the state directory, open the anchor session, start every child, wait until all are
        live; returns self. :class:`~services.learner.store.StateDirInUse` (nothing started) when
        another deployment holds the state directory, :class:`~services.launcher.announce.NamespaceInUse`
        (nothing started, the state directory untouched) when a live deployment announced the namespace."""
        if self.announcement is not None and self.announcement.announced:
            check_namespace_free(self.namespace)
        self._dir_lock.acquire()
        try:
            port = free_port()
            self.anchor = loopback_endpoint(port)
            router = self.announcement.claim(self.anchor) if self.announcement is not None else None
            if router is not None:
                self.session = self._stack.enter_context(open_session(config=router))
            else:
                self.session = self._stack.enter_context(open_session("peer", [self.anchor], multicast=False))
            keys = self.keys
            self._start_spawner()  # it imports torch while the recorder starts
            if self.record is not None:
                self.record.parent.mkdir(parents=True, exist_ok=True)
                # an existing recording is continued in its next segment, never overwritten
                self.continued = recording_segments(self.record)
                seen = []
                if self.continued:
                    self.recording_id = recording_identity(self.continued).recording_id
                    self.recordings = [next_segment(self.record)]
                    seen = [a for p in self.continued for a in ("--seen", str(p))]
                live = []
                if self.viewer:
                    grpc_port, web_port = free_port(), free_port()
                    live = ["--serve-grpc", str(grpc_port), "--web-viewer", str(web_port)]
                    self.viewer_url = f"rerun+http://127.0.0.1:{grpc_port}/proxy"
                    self.web_viewer_url = page_url(self.viewer_url, web_port)
                rec = self._spawn("recorder", entry_module("recorder"),
                                  ["--out", str(self.recordings[0]), "--recording-id", self.recording_id, *seen,
                                   *live],
                                  keys.tokens("recorder"), [keys.events() + " (subscriber)", keys.recorder_status()])
                self._wait_live([rec])
            started = []
            for lid in self.learner_ids if self.with_learner else ():
                args = [*learner_argv(lid, self.learner_ids, self.state_dir),
                        "--chunk-timeout", str(self.chunk_timeout), *self.learner_args]
                if self.record is not None:
                    args += ["--wait-recorder", "20"]
                started.append(self._spawn(
                    lid, entry_module("learner"), args, keys.learner_token(lid),
                    [keys.train("*"), keys.adapt("*"), keys.job_status("*"), keys.jobs(), keys.weights_latest("*")]))
            if self.with_model:
                for i in range(self.model_processes):
                    started.append(self._spawn("model" if i == 0 else f"model-{i + 1}", entry_module("model"), [],
                                               keys.model_service_token("*"), [keys.predict("*"), keys.info("*")]))
            for i in range(self.n_workers):
                started.append(self.start_worker(f"{self.robot}-{i}", wait=False))
            self._wait_live(started)
            if self.with_model and self.model_processes > 1:
                # every model process declares the same kind of token: _wait_live saw one of them
                wait_for_liveliness(self.session, keys.model_service_token("*"), count=self.model_processes,
                                    timeout=self.start_timeout)
            self._announce()
            self._report_problems()
            self._events = EventPublisher(self.session, self.keys)
            if self.supervise:
                self.supervisor = Supervisor(self, self.restart_policy,
                                             **({} if self.report is None else {"report": self.report})).start()
        except BaseException:
            self.stop()
            raise
        return self

    def _report_problems(self, timeout: float = 2.0) -> None:
        """Tell ``report`` (default: the log) each problem the live processes report (a learner's
        quarantined files, say), one line each prefixed by the process's service."""
        say = self.report or log.warning
        try:
            found = list_processes(self.session, self.keys, timeout)
        except Exception as exc:  # asking is a courtesy: the deployment runs without it
            log.debug("could not ask the processes for their problems: %s", exc)
            return
        for about in found:
            for line in about.problems:
                say(f"{about.service}: {line}")

    # ----- inspecting ------------------------------------------------------------------------
    def describe(self) -> str:
        """A table of what runs where: process, pid, liveliness token, keys served, log file."""
        layout = ("zenoh router on 127.0.0.1, every process its authenticated client, ACL on"
                  if self.secure else "peer mesh on 127.0.0.1")
        lines = [f"acnmp deployment '{self.namespace}': anchor {self.anchor} ({layout}, "
                 f"multicast off); state {self.state_dir}"]
        if self.record is not None:
            lines.append(f"recording to {self.recordings[0]}" + (
                "" if not self.continued else f" (continuing {self.record}, {len(self.continued)} earlier file(s): "
                f"`acnmp replay {self.record}` reads them together)"))
        if self.viewer_url is not None:
            lines.append(f"live viewer: rerun --connect {self.viewer_url}   or in a browser: {self.web_viewer_url}")
        lines.append(f"  {'process':<18} {'pid':>7}  liveliness / keys")
        lines.append(f"  {'launcher':<18} {os.getpid():>7}  {self.anchor} (anchor)")
        for c in self.children.values():
            state = "" if c.proc.poll() is None else f" (exited {c.proc.returncode})"
            lines.append(f"  {c.name:<18} {c.pid:>7}  {c.token}{state}")
            for s in c.serves:
                lines.append(f"  {'':<18} {'':>7}    {s}")
            lines.append(f"  {'':<18} {'':>7}    log: {c.log}")
        return "\n".join(lines)

    @property
    def spawner_pid(self) -> int | None:
        """The pid of the spawner that forks this deployment's learners, model processes and
        workers (services/launcher/spawner.py); None without one."""
        return None if self._spawner is None else self._spawner.pid

    def learner_state_dir(self, learner_id: str) -> Path:
        """Where learner ``learner_id`` keeps its state: the deployment's state directory for the
        first, ``<state_dir>/learners/<id>`` for the others."""
        return state_dir_of(self.state_dir, self.learner_ids, learner_id)

    def kill(self, name: str, sig: int = signal.SIGKILL) -> None:
        """Send ``sig`` (default SIGKILL) to child ``name`` and reap it if it was killed. Under
        supervision the child is then restarted, as after any crash (this is how tests make one)."""
        child = self.children[name]
        if child.proc.poll() is None:
            child.proc.send_signal(sig)
            if sig == signal.SIGKILL:
                child.proc.wait(timeout=10)

    def respawn(self, name: str, *, wait: bool = True) -> Child:
        """Start child ``name`` again with the same command line (after it died); returns the new
        Child. (The supervisor does this by itself; this is for a deployment without supervision.)"""
        self.restart_child(name)
        child = self.children[name]
        if wait:
            self._wait_live([child])
        return child

    # ----- what the supervisor uses (services/launcher/supervision.py, Supervised) -------------
    def dead_children(self) -> list[tuple[str, int, int]]:
        """(name, pid, exit code) of every child that has exited."""
        with self._children_lock:
            return [(n, c.pid, c.proc.returncode) for n, c in self.children.items() if c.proc.poll() is not None]

    def restart_child(self, name: str) -> int:
        """Start dead child ``name`` again with its command line (a recorder on a new file); returns
        the new pid. RuntimeError if it is still running."""
        with self._children_lock:
            old = self.children[name]
            if old.proc.poll() is None:
                raise RuntimeError(f"{name} (pid {old.pid}) is still running")
            argv = list(old.argv)
            if name == "recorder":  # the dead recorder's file has no footer and cannot be appended to
                out = argv.index("--out") + 1
                # the new recorder recovers the missed events from the publishers' caches and skips
                # those the earlier files already hold (--seen, one per earlier file)
                argv += ["--seen", argv[out]]
                argv[out] = str(next_segment(self.record, taken=self.recordings))
                self.recordings.append(Path(argv[out]))
            child = Child(name, argv, self._start_process(argv, old.log), old.token, old.serves, old.log)
            self.children[name] = child
            if self.announcement is not None and self.announcement.run is not None:
                self._announce()  # the run file names each child's pid: `acnmp status` checks them
            return child.pid

    def _announce(self) -> None:
        """(Re)write the run file with every child's current pid (no-op when not announced)."""
        if self.announcement is not None:
            self.announcement.publish(self.anchor, str(self.state_dir),
                                      [(c.name, c.pid, c.token) for c in self.children.values()])

    def wait_child_live(self, name: str) -> None:
        """Block until child ``name`` is live (its liveliness token); RuntimeError if it exits first,
        TimeoutError after ``start_timeout``."""
        self._wait_live([self.children[name]])

    def publish_event(self, event: dict) -> None:
        """Publish one event (a ``process`` event of the supervisor) on the launcher's session."""
        if self._events is not None:
            self._events.publish(event)

    @property
    def events(self) -> EventPublisher:
        """The launcher session's event publisher (after :meth:`start`): what an experiment run
        on this deployment publishes through it is recorded before :meth:`stop` ends the recorder."""
        if self._events is None:
            raise RuntimeError("the deployment is not started")
        return self._events

    # ----- stopping --------------------------------------------------------------------------
    def stop(self) -> dict[str, int | None]:
        """Stop the children with SIGTERM (SIGKILL after ``stop_timeout``), in two overlapping steps:
        the learner, the model and the workers at once (the learner abandons the batch in flight
        of its running job, which is saved ``interrupted`` and resumes on the next start, so it
        needs no worker to stop), then, as soon as the learner is gone and its last events are out
        and the recorder's counts hold every roll-out published through :attr:`events` (at most
        ``stop_timeout`` s), the recorder (it records them and writes its footer). Closes the session, merges the
        recorder's files after a restart, unlocks the state directory. Returns {name: exit code};
        names SIGKILLed are added to ``killed``. Supervision ends first, so nothing stopped here is
        restarted. Safe to call twice.
        """
        if self.supervisor is not None:
            self.supervisor.stop()
        with self._children_lock:
            children = dict(self.children)
        learner = [c for n, c in children.items() if n in self.learner_ids]
        others = [c for n, c in children.items() if n not in (*self.learner_ids, "recorder")]
        recorder = [c for n, c in children.items() if n == "recorder"]
        deadline = time.monotonic() + self.stop_timeout
        self._terminate(learner + others)
        self._reap(learner, deadline)
        if recorder and self._events is not None and not self._events.wait_recorded(self.stop_timeout):
            log.warning("the recorder did not confirm every roll-out published through the launcher "
                        "within %.0f s; stopping it anyway", self.stop_timeout)
        self._terminate(recorder)
        self._reap(others, deadline)
        self._reap(recorder, time.monotonic() + self.stop_timeout)
        if self._spawner is not None and self._owns_spawner:
            self._spawner.close()
        self._spawner = None
        self._stack.close()
        self.session = None
        recordings = list(self.recordings)
        self._merge_recordings()
        for rec in recordings[1:]:  # merged away; the first's marks serve the session that continues it
            marks_path(rec).unlink(missing_ok=True)
        if self.announcement is not None:
            self.announcement.withdraw()
        self._dir_lock.release()
        codes = {n: c.proc.returncode for n, c in self.children.items()}
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None
        return codes

    @staticmethod
    def _terminate(group: Sequence[Child]) -> None:
        for c in group:
            if c.proc.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    c.proc.send_signal(signal.SIGTERM)

    def _reap(self, group: Sequence[Child], deadline: float) -> None:
        """Wait for ``group`` to exit until ``deadline`` (monotonic s); SIGKILL what is left."""
        for c in group:
            try:
                c.proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                c.proc.kill()
                c.proc.wait(timeout=10)
                self.killed.append(c.name)

    def _merge_recordings(self) -> None:
        """After a recorder restart: merge this session's files into its first one (which has no
        footer, as its writer was killed) and remove the others; on failure keep them all and say so."""
        if len(self.recordings) < 2:
            return
        rerun = Path(sys.executable).with_name("rerun")
        first = self.recordings[0]
        merged = first.with_name(f".{first.name}.merged")
        out = subprocess.run([str(rerun), "rrd", "merge", "--continue-on-error", *map(str, self.recordings),
                              "-o", str(merged)], capture_output=True, text=True, timeout=300)
        if out.returncode != 0 or not merged.is_file():
            (self.report or log.warning)(f"could not merge the recordings {[str(p) for p in self.recordings]}: "
                                   f"{out.stderr.strip().splitlines()[-1:] or out.returncode}")
            return
        os.replace(merged, first)
        for extra in self.recordings[1:]:
            extra.unlink(missing_ok=True)
        self.recordings = [first]

    def __enter__(self) -> "LocalDeployment":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


class _Kept:
    """The spawner this process keeps for its deployments (:func:`share_spawner`)."""

    lock = threading.Lock()
    log_file: Path | None = None  # None: not sharing
    per_child: frozenset[str] = frozenset()  # besides PER_CHILD_ENV (the Spawner adds it)
    spawner: Spawner | None = None


def share_spawner(log_file: str | os.PathLike | None, per_child_env: Iterable[str] = ()) -> None:
    """Keep one spawner for every :class:`LocalDeployment` this process starts, its output appended
    to ``log_file``; ``None``: close it and give each deployment its own again (close it when no
    deployment runs: a child still running stops once its spawner has exited, as it watches it).

    For a process that starts many deployments (a test session, a benchmark): torch is then imported
    once per process instead of once per deployment. The first deployment that forks starts it, with
    every module of :data:`~services.launcher.spawner.FORKABLE`; a later one forks from it when its
    children's environment is the spawner's but for
    :data:`~services.launcher.spawner.PER_CHILD_ENV` and ``per_child_env`` (variables of the
    caller's that change between its deployments and that no service reads at import), else it
    starts its own as without sharing. The kept spawner exits with this process, and so do the
    children it forked."""
    with _Kept.lock:
        spawner, _Kept.spawner = _Kept.spawner, None
        _Kept.log_file = None if log_file is None else Path(log_file)
        _Kept.per_child = frozenset(per_child_env)
    if spawner is not None:
        spawner.close()


def _kept_spawner(env: dict[str, str]) -> Spawner | None:
    """The kept spawner (started now if there is none running) when sharing and it can fork children
    of environment ``env``; else None."""
    with _Kept.lock:
        if _Kept.log_file is None:
            return None
        if _Kept.spawner is None or not _Kept.spawner.running:
            _Kept.log_file.parent.mkdir(parents=True, exist_ok=True)
            _Kept.spawner = Spawner(list(FORKABLE), env, ROOT, _Kept.log_file, per_child_env=_Kept.per_child)
        return _Kept.spawner if _Kept.spawner.accepts_env(env) else None


def child_env() -> dict[str, str]:
    """The environment of a launcher's child process: the project (and the launcher's directory) on
    PYTHONPATH, one torch thread, unbuffered output, no Rerun analytics, the robot plugins this
    process loaded, and the launcher's pid to watch."""
    # the launcher's directory too: a robot plugin named as module:attr is found from where it was named
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.getcwd(), os.environ.get("PYTHONPATH")])),
               RERUN_ANALYTICS="0", OMP_NUM_THREADS="1", PYTHONUNBUFFERED="1")
    # robot plugins this process loaded by reference reach every child (the learner validates jobs
    # of the kind, the recorder draws it)
    env[PLUGINS_ENV] = plugins_for_children()
    env[PARENT_PID_ENV] = str(os.getpid())  # children stop when the launcher dies (even by kill -9)
    env.pop("RERUN", None)  # RERUN=off would silence the recorder
    return env


def _popen(argv: list[str], log: Path, env: dict[str, str]) -> subprocess.Popen:
    """Start a child in its own session (a terminal's Ctrl-C reaches only the launcher), output to ``log``;
    it watches the launcher's pid (services.transport.lifetime.watch_parent)."""
    with open(log, "ab") as out:
        return subprocess.Popen(argv, cwd=ROOT, env=env, stdin=subprocess.DEVNULL, stdout=out,
                                stderr=subprocess.STDOUT, start_new_session=True)


#: What marks a line of a child's log as an error: a log record of level ERROR or CRITICAL (the
#: format of services/transport/service.py), a command's one-line error, a Python exception's last
#: line.
_ERROR_LINE = re.compile(r"( (ERROR|CRITICAL) |: error: |^[A-Za-z_][\w.]*(Error|Exception|Exit)\b)")


def last_error_line(path: Path | None) -> str:
    """The last line of the log ``path`` that says an error (see :data:`_ERROR_LINE`), else its last
    line that is not empty ('' if none or unreadable); at most 500 characters."""
    lines = [ln.strip() for ln in log_tail(path, 200).splitlines() if ln.strip()]
    errors = [ln for ln in lines if _ERROR_LINE.search(ln)]
    line = (errors or lines or [""])[-1]
    return line if len(line) <= 500 else line[:497] + "..."


def log_tail(path: Path | None, n: int = 20) -> str:
    """Last ``n`` lines of a log file ('' if unreadable)."""
    try:
        return "\n".join(Path(path).read_text(errors="replace").splitlines()[-n:])
    except (OSError, TypeError):
        return ""
