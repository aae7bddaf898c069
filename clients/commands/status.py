"""``acnmp status``: the deployments running on this machine, their processes and health."""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass


def register(subparsers) -> None:
    """Add the ``status`` sub-command."""
    from services.transport.argtypes import seconds

    p = subparsers.add_parser("status", help="list the running deployments (acnmp up), their processes and health",
                              description=__doc__.splitlines()[0].split(": ", 1)[1])
    p.add_argument("--namespace", "-n", default=None, help="only this deployment")
    p.add_argument("--timeout", type=seconds(zero=True), default=2.0,
                   help="seconds to wait for liveliness (default: %(default)s)")
    p.add_argument("--json", action="store_true", help="print the status as JSON")
    p.set_defaults(func=run)


@dataclass
class ProcessHealth:
    """One process of a deployment: name, pid, whether the pid runs and its liveliness token is seen."""

    name: str
    pid: int
    running: bool
    live: bool

    @property
    def health(self) -> str:
        """``ok`` (its token is seen on zenoh: it serves, even if restarted under another pid),
        ``no token`` (the pid runs but is not seen) or ``exited``."""
        return "ok" if self.live else "no token" if self.running else "exited"


def process_health(run, timeout: float) -> list[ProcessHealth]:
    """The health of each process of run file ``run``: its pid, and its liveliness token seen
    through a session opened with the deployment's client credentials (one liveliness query per
    kind of token)."""
    import zenoh

    from clients.discovery import resolve
    from services.transport import alive_tokens, open_session
    from services.transport.runfile import pid_alive

    target = resolve(run.namespace, [run.anchor], run.credentials or None, None if run.credentials else "peer")
    try:
        with open_session(target.mode, None, target.connect, target.config_file, open_timeout=timeout) as session:
            # one liveliness query per kind of token: the access table grants each family, never acnmp/<ns>/**
            tokens = [zenoh.KeyExpr(t) for family in sorted({p.token for p in run.processes})
                      for t in alive_tokens(session, family, timeout)]
    except ConnectionError:
        tokens = []
    return [ProcessHealth(p.name, p.pid, pid_alive(p.pid), any(zenoh.KeyExpr(p.token).intersects(t) for t in tokens))
            for p in run.processes]


def run(args) -> int:
    """Print every running deployment (or the one of ``--namespace``): anchor, launcher pid, state
    directory, and per process its pid and health. Exit 0; 1 when none runs."""
    from services.transport.runfile import running, runtime_dir

    runs = [r for r in running() if args.namespace is None or r.namespace == args.namespace]
    report = []
    for r in runs:
        procs = process_health(r, args.timeout)
        report.append({"namespace": r.namespace, "anchor": r.anchor, "pid": r.pid, "state_dir": r.state_dir,
                       "secured": bool(r.credentials), "credentials": r.credentials,
                       "processes": [{"name": p.name, "pid": p.pid, "health": p.health} for p in procs]})
    if args.json:
        print(json.dumps(report, indent=2))
    elif not report:
        which = f" of namespace {args.namespace!r}" if args.namespace else ""
        print(f"no deployment{which} is running (run files in {runtime_dir(create=False)})", file=sys.stderr)
    for d in [] if args.json else report:
        auth = "authenticated (client credentials " + d["credentials"] + ")" if d["secured"] else "not authenticated"
        print(f"deployment '{d['namespace']}': anchor {d['anchor']}, launcher pid {d['pid']}, {auth}")
        print(f"  state {d['state_dir']}")
        for p in d["processes"]:
            print(f"  {p['name']:<18} {p['pid']:>7}  {p['health']}")
    return 0 if report else 1
