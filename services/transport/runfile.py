"""Discovery on one machine: the run file a running deployment leaves for its user's tools.

``acnmp up`` writes ``<runtime dir>/<namespace>/run.json`` (mode 0600, in a 0700 directory that
also holds the deployment's secrets, services/transport/auth.py) with the anchor endpoint, the
namespace, the launcher's pid, the credentials a client and an operator use, and its processes.
It is removed on a clean exit; a run file whose pid is dead is stale and ignored (and removed
when found). ``acnmp query``, :class:`clients.client.ACNMPClient` and ``acnmp status`` read it.

The runtime directory is ``$ACNMP_RUNTIME_DIR`` (tests point it at a temporary directory), else
``$XDG_RUNTIME_DIR/acnmp``, else ``~/.cache/acnmp/run``, else ``/tmp/acnmp-<uid>``; it is created
with mode 0700.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

from .auth import write_private
from .keys import DEFAULT_NAMESPACE
from .lifetime import pid_alive

#: Environment variable overriding the runtime directory.
RUNTIME_ENV = "ACNMP_RUNTIME_DIR"
RUN_FILE = "run.json"


def runtime_dir(create: bool = True) -> Path:
    """The directory holding one sub-directory per running deployment (see the module docstring);
    created with mode 0700 when ``create``."""
    candidates = [os.environ.get(RUNTIME_ENV)]
    if os.environ.get("XDG_RUNTIME_DIR"):
        candidates.append(os.path.join(os.environ["XDG_RUNTIME_DIR"], "acnmp"))
    candidates += [os.path.join(os.path.expanduser("~"), ".cache", "acnmp", "run"),
                   os.path.join(tempfile.gettempdir(), f"acnmp-{os.getuid()}")]
    last_error: OSError | None = None
    for cand in filter(None, candidates):
        path = Path(cand)
        if not create:
            return path
        try:
            path.mkdir(parents=True, exist_ok=True, mode=0o700)
            os.chmod(path, 0o700)
            return path
        except OSError as exc:  # e.g. a read-only home: try the next place
            last_error = exc
    raise OSError(f"no usable runtime directory for acnmp: {last_error}")


def deployment_dir(namespace: str) -> Path:
    """``<runtime dir>/<namespace>``: the run file and the secrets of that deployment."""
    return runtime_dir() / namespace


@dataclass
class ProcessEntry:
    """One process of a deployment: name, pid and the liveliness token it declares."""

    name: str
    pid: int
    token: str


@dataclass
class RunFile:
    """What a running deployment tells its user's tools (``run.json``).

    anchor : endpoint to connect to. namespace : key prefix. pid : the launcher's pid.
    credentials : zenoh config file of role ``client`` (queries only), or "" when the deployment
    is not secured. operator_credentials : the same for role ``operator`` (may start jobs).
    state_dir : learner state. processes : the children.
    """

    namespace: str
    anchor: str
    pid: int
    credentials: str = ""
    operator_credentials: str = ""
    state_dir: str = ""
    processes: list[ProcessEntry] = field(default_factory=list)

    @property
    def path(self) -> Path:
        """Where this run file lives."""
        return deployment_dir(self.namespace) / RUN_FILE

    def alive(self) -> bool:
        """Whether the launcher's pid is still running."""
        return pid_alive(self.pid)

    def write(self) -> Path:
        """Write (atomically, mode 0600) and return the path."""
        self.path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        return write_private(self.path, json.dumps(asdict(self), indent=2) + "\n")

    def remove(self) -> None:
        """Delete the run file (not the secrets next to it)."""
        try:
            self.path.unlink()
        except FileNotFoundError:
            pass

    @classmethod
    def read(cls, path: str | os.PathLike) -> "RunFile | None":
        """The run file at ``path``, or None if missing or not a run file."""
        try:
            data = json.loads(Path(path).read_text(encoding="utf-8"))
            procs = [ProcessEntry(str(p["name"]), int(p["pid"]), str(p["token"])) for p in data.get("processes", [])]
            return cls(str(data["namespace"]), str(data["anchor"]), int(data["pid"]),
                       str(data.get("credentials", "")), str(data.get("operator_credentials", "")),
                       str(data.get("state_dir", "")), procs)
        except (OSError, ValueError, KeyError, TypeError):
            return None


def running() -> list[RunFile]:
    """The run files of live deployments, sorted by namespace; a stale one (dead pid) is removed
    with the secrets beside it."""
    base = runtime_dir(create=False)
    found = []
    for path in sorted(base.glob(f"*/{RUN_FILE}")) if base.is_dir() else []:
        run = RunFile.read(path)
        if run is None:
            continue
        if run.alive():
            found.append(run)
        else:  # its launcher died without cleaning up (kill -9): drop the run file and the secrets
            shutil.rmtree(path.parent, ignore_errors=True)
    return found


class DeploymentNotFound(OSError):
    """No running deployment matches (an OSError: the CLI prints its message as one line)."""


def find(namespace: str | None = None) -> RunFile:
    """The running deployment of ``namespace`` (None: the default namespace); when that one does
    not run and ``namespace`` is None or the default, the only one running if there is exactly
    one. Raises :class:`DeploymentNotFound`."""
    runs = running()
    for run in runs:
        if run.namespace == (namespace or DEFAULT_NAMESPACE):
            return run
    if len(runs) == 1 and (namespace is None or namespace == DEFAULT_NAMESPACE):
        return runs[0]
    names = ", ".join(r.namespace for r in runs) or "none"
    want = f" of namespace {namespace!r}" if namespace is not None else ""
    raise DeploymentNotFound(f"no running deployment{want} found in {runtime_dir(create=False)} "
                             f"(running: {names}); start one with `acnmp up`")

