"""A local deployment's run file and, when secured, its secrets: what :class:`LocalDeployment`
does with ``secure=True`` or ``announce=True``, kept out of deployment.py.

:class:`Announcement` claims ``<runtime dir>/<namespace>/`` (refusing when a live deployment of
that namespace holds it), writes the secrets there (services/transport/auth.py), gives the
anchor's router config and each child's ``--config``, writes the run file once every child is
live (services/transport/runfile.py) and removes all of it when the deployment stops.

A secured deployment that is not announced (``acnmp experiment ... --distributed``: a private
deployment of one run, no run file, so ``acnmp query`` never picks it) keeps its secrets in a
directory of its own instead (``directory=``, the launcher uses ``<state dir>/secrets``).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Iterable

import zenoh

from services.transport.auth import DeploymentSecrets
from services.transport.runfile import ProcessEntry, RunFile, deployment_dir


class NamespaceInUse(RuntimeError):
    """Another live deployment announced the same namespace on this machine."""


def check_namespace_free(namespace: str) -> None:
    """Raise :class:`NamespaceInUse` if a live deployment (another process) announced ``namespace`` on
    this machine (its run file in :func:`~services.transport.runfile.deployment_dir`)."""
    other = RunFile.read(deployment_dir(namespace) / "run.json")
    if other is not None and other.alive() and other.pid != os.getpid():
        raise NamespaceInUse(f"a deployment of namespace {namespace!r} is already running "
                             f"(launcher pid {other.pid}, anchor {other.anchor}); stop it or use --namespace")


def role_of(child_name: str) -> str:
    """The zenoh username a child authenticates as: ``worker-<id>`` -> ``worker``, ``model-<i>`` (a
    further model process) -> ``model``, else its name."""
    if child_name.startswith("worker"):
        return "worker"
    return "model" if child_name.startswith("model-") else child_name


class Announcement:
    """The run file of one deployment of ``namespace`` and, when ``secure``, its secrets.

    ``directory`` None: announced, in ``<runtime dir>/<namespace>/`` with a run file. A directory:
    not announced (no run file, no namespace claim), the secrets written there (mode 0700).
    """

    def __init__(self, namespace: str, secure: bool = True, directory: str | os.PathLike | None = None) -> None:
        self.namespace = namespace
        self.secure = secure
        self.announced = directory is None
        self.directory = deployment_dir(namespace) if directory is None else Path(directory)
        self.secrets = DeploymentSecrets(self.directory)
        self.run: RunFile | None = None
        self._claimed = False

    def claim(self, anchor: str) -> zenoh.Config | None:
        """Refuse (:class:`NamespaceInUse`) if a live deployment announced this namespace; else,
        when secure, write fresh secrets for ``anchor`` and return the anchor's router config
        (None when not secure: the anchor is a peer of the mesh)."""
        if self.announced:
            check_namespace_free(self.namespace)
        self.secrets.remove()  # a stale deployment's secrets
        self._claimed = True
        if not self.secure:
            return None
        self.secrets.create(anchor)
        return self.secrets.router_config([anchor])

    def child_args(self, child_name: str) -> list[str]:
        """The extra command-line arguments of a child: its role's zenoh config file (none when
        not secure)."""
        return ["--config", str(self.secrets.config_path(role_of(child_name)))] if self.secure else []

    def publish(self, anchor: str, state_dir: str, processes: Iterable[tuple[str, int, str]]) -> RunFile | None:
        """Write the run file: ``processes`` is (name, pid, liveliness token) per child; returns it
        (None, writing nothing, when not announced)."""
        if not self.announced:
            return None
        creds = {r: str(self.secrets.config_path(r)) if self.secure else "" for r in ("client", "operator")}
        self.run = RunFile(self.namespace, anchor, os.getpid(),
                           credentials=creds["client"], operator_credentials=creds["operator"],
                           state_dir=str(state_dir),
                           processes=[ProcessEntry(n, int(p), t) for n, p, t in processes])
        self.run.write()
        return self.run

    def withdraw(self) -> None:
        """Remove the run file and the secrets (only if this deployment claimed them)."""
        if not self._claimed:
            return
        if self.run is not None:
            self.run.remove()
        self.secrets.remove()
        self._claimed = False
