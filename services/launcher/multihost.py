"""A secured deployment spread over hosts: each process on a network namespace of its own.

:class:`MultiHostDeployment` starts what ``docker-compose.yml`` + ``docker-compose.secure.yml``
start, one process per host of a :class:`~services.launcher.netns.HostNetwork`:

* host ``router``: the zenoh router (``python -m services.transport.router``), listening on
  ``tls/0.0.0.0:7447``;
* hosts ``recorder``, ``learner``, ``model``, ``worker-0`` ... ``worker-<n-1>``: one service each,
  in client mode, connecting to ``tls/router:7447``; with ``learners=K`` the learners ``learner``,
  ``learner-2`` ... ``learner-K``, each on a host of its own with the shared ``--learners`` list
  and a state directory of its own (as ``acnmp up --learners K`` gives them);
* host ``client``: no process of its own; :meth:`MultiHostDeployment.client_argv` runs commands
  there (``acnmp ...`` with the operator's or the client's config).

The zenoh configs are those ``acnmp credentials DIR --tls CERTS`` writes for the compose files
(:func:`services.transport.auth.write_router_deployment`: a fresh password per role, the router's
dictionary and ACL, mutual TLS) and the certificates those of ``scripts/make_tls_certs.sh``, made
for the name ``router``. Each process gets ``ACNMP_HOST=<its host>`` (a container gets its own host
name; namespaces share the machine's), which ``acnmp status`` shows (services/transport/about.py).

Each child's first line on stdout is its ready line (services/transport/service.py): the
deployment waits for it (an event, not a poll), and tees the child's output into
``<log_dir>/<process>.log``. Children watch the launcher's pid, so they stop with it even after
``kill -9``; :meth:`stop` sends SIGTERM (SIGKILL after ``stop_timeout``) and removes the network.
"""
from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

from services.learner.ownership import learner_argv, numbered_ids, state_dir_of
from services.transport.about import HOST_ENV
from services.transport.auth import write_router_deployment

from .deployment import ROOT, child_env, log_tail
from .netns import HostNetwork
from .processes import entry_module

PORT = 7447


@dataclass
class HostProcess:
    """One process of the deployment: its name (also its host's), argv, Popen and log; ``ready``
    is set at its first stdout line (kept in ``ready_line``)."""

    name: str
    argv: list[str]
    proc: subprocess.Popen
    log: Path
    ready: threading.Event = field(default_factory=threading.Event)
    ready_line: str = ""
    lines: list[str] = field(default_factory=list)
    changed: threading.Condition = field(default_factory=threading.Condition)


class MultiHostDeployment:
    """The deployment of the module docstring: ``with MultiHostDeployment("ns", workers=2) as dep:``.

    Parameters: ``namespace`` (key prefix), ``workers`` (point-mass workers, or ``robot``'s),
    ``record`` (.rrd file of the recorder; None: no recorder host), ``state_dir`` (the learner's;
    default a temporary directory), ``chunk_timeout`` (seconds a worker's chunk may take before the
    learner re-sends it), ``start_timeout``/``stop_timeout`` (seconds), ``work_dir`` (certificates,
    configs and logs; default a temporary directory removed at stop). ``one_host``: every process
    on the router's host, so the same processes, configs and TLS talk over that namespace's
    loopback: the baseline a benchmark compares the links against. ``extra_workers``: robot kinds
    of one more worker each, on hosts ``worker-<kind>`` (ids ``<kind>-0``). ``learners``: how many
    learners (ids and state directories: :func:`~services.learner.ownership.numbered_ids`,
    :meth:`learner_state_dir`); ``learner_args``: more options for every learner (``--jobs 2``);
    ``model``: False for no model service (and no ``model`` host).
    """

    def __init__(self, namespace: str = "default", *, workers: int = 2, robot: str = "point2d",
                 record: str | os.PathLike | None = None, state_dir: str | os.PathLike | None = None,
                 chunk_timeout: float = 60.0, start_timeout: float = 60.0, stop_timeout: float = 8.0,
                 work_dir: str | os.PathLike | None = None, one_host: bool = False,
                 extra_workers: Sequence[str] = (), learners: int = 1, learner_args: Sequence[str] = (),
                 model: bool = True) -> None:
        if workers < 1:
            raise ValueError(f"workers: expected >= 1, got {workers}")
        #: the learners' ids, each also the name of its process and its host
        self.learner_ids = numbered_ids(learners)
        self.learner_args, self.with_model = list(learner_args), bool(model)
        self.namespace, self.robot, self.n_workers = namespace, robot, int(workers)
        self.record = None if record is None else Path(record).resolve()
        self.chunk_timeout, self.start_timeout, self.stop_timeout = chunk_timeout, start_timeout, stop_timeout
        self._stack = contextlib.ExitStack()
        self.work_dir = Path(work_dir) if work_dir is not None else Path(
            self._stack.enter_context(tempfile.TemporaryDirectory(prefix="acnmp-hosts-")))
        self.state_dir = Path(state_dir).resolve() if state_dir is not None else self.work_dir / "state"
        self.secrets, self.certs, self.log_dir = (self.work_dir / "secrets", self.work_dir / "tls",
                                                  self.work_dir / "logs")
        names = ["router", *(["recorder"] if self.record is not None else []), *self.learner_ids,
                 *(["model"] if self.with_model else []),
                 *[f"worker-{i}" for i in range(self.n_workers)], *[f"worker-{k}" for k in extra_workers], "client"]
        self.extra_workers = tuple(extra_workers)
        self.one_host = bool(one_host)
        self.network = HostNetwork(["router", "client"] if self.one_host else names)
        self.processes: dict[str, HostProcess] = {}
        self._tees: list[threading.Thread] = []

    # ----- starting ----------------------------------------------------------------------------
    def start(self) -> "MultiHostDeployment":
        """Make the network, the certificates and configs, start the router, then the recorder,
        then the others; wait for every ready line. On failure stop what started and raise."""
        try:
            self.network.create()
            subprocess.run(["bash", str(ROOT / "scripts" / "make_tls_certs.sh"), str(self.certs), "router"],
                           check=True, capture_output=True, timeout=60)
            write_router_deployment(self.secrets, f"tls/0.0.0.0:{PORT}", f"tls/router:{PORT}",
                                    tls_dir=str(self.certs))
            self._wait([self._spawn("router", "router", "router", [])])
            if self.record is not None:
                self.record.parent.mkdir(parents=True, exist_ok=True)
                self._wait([self._spawn("recorder", "recorder", "recorder", ["--out", str(self.record)])])
            learner_args = ["--chunk-timeout", str(self.chunk_timeout), *self.learner_args]
            if self.record is not None:
                learner_args += ["--wait-recorder", "20"]
            started = [self._spawn(lid, "learner", "learner",
                                   [*learner_argv(lid, self.learner_ids, self.state_dir), *learner_args])
                       for lid in self.learner_ids]
            if self.with_model:
                started.append(self._spawn("model", "model", "model", []))
            for i in range(self.n_workers):
                started.append(self._spawn(f"worker-{i}", "worker", "worker",
                                           ["--robot", self.robot, "--id", f"{self.robot}-{i}"]))
            for kind in self.extra_workers:
                started.append(self._spawn(f"worker-{kind}", "worker", "worker", ["--robot", kind, "--id", f"{kind}-0"]))
            self._wait(started)
        except BaseException:
            self.stop()
            raise
        return self

    def _env(self, host: str) -> dict[str, str]:
        return {**child_env(), HOST_ENV: self.host(host).name}

    def config(self, role: str) -> Path:
        """The zenoh config file of ``role`` (``operator``, ``client``, ``worker`` ...)."""
        return self.secrets / f"{role}.json5"

    def _spawn(self, name: str, process: str, role: str, args: Sequence[str]) -> HostProcess:
        self.log_dir.mkdir(parents=True, exist_ok=True)
        argv = self.host(name).exec_argv(
            [sys.executable, "-m", entry_module(process), "--config", str(self.config(role)),
             "--namespace", self.namespace, *args])
        log = self.log_dir / f"{name}.log"
        proc = subprocess.Popen(argv, cwd=ROOT, env=self._env(name), stdin=subprocess.DEVNULL,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
        child = HostProcess(name, argv, proc, log)
        out = open(log, "a", encoding="utf-8")
        self._stack.callback(out.close)
        for stream, ready in ((proc.stdout, True), (proc.stderr, False)):
            tee = threading.Thread(target=self._tee, args=(child, stream, out, ready), name=f"tee-{name}", daemon=True)
            tee.start()
            self._tees.append(tee)
        self.processes[name] = child
        return child

    @staticmethod
    def _tee(child: HostProcess, stream, out, ready: bool) -> None:
        """Copy one of the child's streams into its log and ``lines``; on stdout, set ``ready`` at the
        first line, the ready line (or at the end of the stream)."""
        for line in stream:
            with child.changed:
                out.write(line)
                out.flush()
                child.lines.append(line.rstrip("\n"))
                if ready and not child.ready.is_set():
                    child.ready_line = line.strip()
                    child.ready.set()
                child.changed.notify_all()
        if ready:
            child.ready.set()

    def _wait(self, children: Sequence[HostProcess]) -> None:
        for child in children:
            if not child.ready.wait(self.start_timeout):
                raise TimeoutError(f"{child.name} not ready after {self.start_timeout} s; log {child.log}")
            if not child.ready_line or child.proc.poll() is not None:
                child.proc.wait(timeout=10)
                raise RuntimeError(f"{child.name} exited with code {child.proc.returncode} before it was ready; "
                                   f"log {child.log}:\n{log_tail(child.log)}")

    # ----- using -------------------------------------------------------------------------------
    def host(self, name: str):
        """The :class:`~services.launcher.netns.Host` process or host ``name`` runs on (the router's
        for every process with ``one_host``, the client host included)."""
        return self.network.hub if self.one_host else self.network.hosts[name]

    def learner_state_dir(self, learner_id: str) -> Path:
        """Where learner ``learner_id`` keeps its state (``state_dir`` for the first learner,
        ``<state_dir>/learners/<id>`` for the others)."""
        return state_dir_of(self.state_dir, self.learner_ids, learner_id)

    def client_argv(self, argv: Sequence[str], *, host: str = "client") -> list[str]:
        """``argv`` (e.g. ``[python, -m, clients.cli, query, skills, --config, ...]``) run on ``host``."""
        return self.host(host).exec_argv(argv)

    def acnmp(self, *args: str, role: str = "operator", host: str = "client", timeout: float = 120.0,
              config: str | os.PathLike | None = None) -> subprocess.CompletedProcess:
        """Run ``acnmp ARGS --namespace NS --config <role's config, or config>`` on ``host``; returns the
        completed process (text stdout and stderr)."""
        argv = self.client_argv([sys.executable, "-m", "clients.cli", *args, "--namespace", self.namespace,
                                 "--config", str(config or self.config(role))], host=host)
        return subprocess.run(argv, cwd=ROOT, env=self._env(host), capture_output=True, text=True, timeout=timeout)

    def popen(self, argv: Sequence[str], *, host: str = "client", **kwargs) -> subprocess.Popen:
        """Start ``argv`` on ``host`` with the deployment's environment (``kwargs`` to Popen)."""
        return subprocess.Popen(self.client_argv(argv, host=host), cwd=ROOT, env=self._env(host), **kwargs)

    def cut(self, host: str) -> None:
        """Take ``host``'s link down (:meth:`HostNetwork.cut`)."""
        self.network.cut(host)

    def heal(self, host: str) -> None:
        """Bring ``host``'s link back (:meth:`HostNetwork.heal`)."""
        self.network.heal(host)

    def log(self, name: str) -> str:
        """The output of process ``name`` so far (stdout and stderr, one line each)."""
        child = self.processes[name]
        with child.changed:
            return "\n".join(child.lines)

    def wait_for_line(self, name: str, text: str, timeout: float = 60.0) -> str:
        """Block until process ``name`` writes a line containing ``text``; return it. TimeoutError
        (with the output's tail) after ``timeout`` s."""
        child = self.processes[name]
        with child.changed:
            if child.changed.wait_for(lambda: any(text in ln for ln in child.lines), timeout=timeout):
                return next(ln for ln in child.lines if text in ln)
            tail = "\n".join(child.lines[-20:])
        raise TimeoutError(f"{name} wrote no line with {text!r} in {timeout} s; its last lines:\n{tail}")

    # ----- stopping ----------------------------------------------------------------------------
    def stop(self) -> dict[str, int | None]:
        """SIGTERM every process (the recorder last, once the others are gone, so it writes its
        footer), SIGKILL after ``stop_timeout``; remove the network and the work directory.
        Returns {process: exit code}. Safe to call twice."""
        first = [c for n, c in self.processes.items() if n not in ("recorder", "router")]
        last = [c for n, c in self.processes.items() if n == "recorder"] + \
               [c for n, c in self.processes.items() if n == "router"]
        for group in (first, last):
            for c in group:
                if c.proc.poll() is None:
                    with contextlib.suppress(ProcessLookupError):
                        c.proc.send_signal(signal.SIGTERM)
            for c in group:
                try:
                    c.proc.wait(timeout=self.stop_timeout)
                except subprocess.TimeoutExpired:
                    c.proc.kill()
                    c.proc.wait(timeout=10)
        self.network.remove()
        for tee in self._tees:  # the streams end with the processes; then the logs can be closed
            tee.join(timeout=5)
        codes = {n: c.proc.returncode for n, c in self.processes.items()}
        self._stack.close()
        return codes

    def __enter__(self) -> "MultiHostDeployment":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

