"""``acnmp status``: the deployments running on this machine, their processes and their health.

With ``--config``, a deployment on other hosts: every process that answers, and its host. A
process is healthy when its liveliness token is seen and it reports no problem (the learner
reports a state write that failed, a job loop that stopped, the files in its quarantine). Exit 0
when every process of every deployment listed is healthy; 1 when one is not (it exited, was
given up by its launcher, shows no token, or reports a problem) or when none runs."""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass


def register(subparsers) -> None:
    """Add the ``status`` sub-command."""
    from services.transport.argtypes import seconds

    # the module docstring without its title, as one paragraph
    description = " ".join(__doc__.split(": ", 1)[1].split()).replace("``", "")
    p = subparsers.add_parser("status", help="list the running deployments (acnmp up), their processes and health",
                              description=description)
    p.add_argument("--namespace", "-n", default=None, help="only this deployment")
    p.add_argument("--timeout", type=seconds(zero=True), default=2.0,
                   help="seconds to wait for liveliness (default: %(default)s)")
    p.add_argument("--json", action="store_true", help="print the status as JSON")
    p.add_argument("--config", default=None, metavar="FILE",
                   help="ask the deployment this zenoh config reaches (`acnmp credentials`' client.json5: a router "
                        "on another host) for its processes and their hosts, instead of this machine's run files")
    p.set_defaults(func=run)


@dataclass
class ProcessHealth:
    """One process of a deployment: name, pid, whether the pid runs and its liveliness token is
    seen, its host and the problems it reports (its ``about`` reply)."""

    name: str
    pid: int
    running: bool
    live: bool
    host: str = ""
    problems: tuple[str, ...] = ()

    @property
    def health(self) -> str:
        """``ok`` (its token is seen on zenoh: it serves, even if restarted under another pid, and
        it reports no problem), ``problems`` (seen, but it reports some), ``no token`` (the pid
        runs but is not seen) or ``exited``."""
        if not self.live:
            return "no token" if self.running else "exited"
        return "problems" if self.problems else "ok"


def process_health(run, timeout: float) -> list[ProcessHealth]:
    """The health of each process of run file ``run``: its pid, its liveliness token and its
    ``about`` reply (host, problems), seen through a session opened with the deployment's client
    credentials (one liveliness query per kind of token). Asked again until every running process
    has been seen or ``timeout`` s have passed: a new peer session sees the other peers only once
    it has found them, so one look may miss a healthy process."""
    import time

    import zenoh

    from clients.discovery import resolve
    from services.transport import Keyspace, alive_tokens, open_session
    from services.transport.about import list_processes
    from services.transport.runfile import pid_alive

    target = resolve(run.namespace, [run.anchor], run.credentials or None, None if run.credentials else "peer")
    families = sorted({p.token for p in run.processes})
    tokens: list[zenoh.KeyExpr] = []
    about: dict = {}

    def seen(p) -> bool:
        return p.pid in about and any(zenoh.KeyExpr(p.token).intersects(t) for t in tokens)

    deadline = time.monotonic() + timeout
    try:
        with open_session(target.mode, None, target.connect, target.config_file, open_timeout=timeout) as session:
            while True:
                look = min(1.0, max(0.1, deadline - time.monotonic()))
                # one liveliness query per kind of token: the access table grants each family, never acnmp/<ns>/**
                tokens += [zenoh.KeyExpr(t) for family in families for t in alive_tokens(session, family, look)]
                about.update({a.pid: a for a in list_processes(session, Keyspace(run.namespace), look)})
                if all(seen(p) for p in run.processes if pid_alive(p.pid)) or time.monotonic() >= deadline:
                    break
                time.sleep(0.1)
    except ConnectionError:
        pass
    return [ProcessHealth(p.name, p.pid, pid_alive(p.pid), any(zenoh.KeyExpr(p.token).intersects(t) for t in tokens),
                          about[p.pid].host if p.pid in about else "", about[p.pid].problems if p.pid in about else ())
            for p in run.processes]


def remote_status(namespace: str, config: str, timeout: float) -> list:
    """The :class:`~services.transport.about.ProcessAbout` of every process of ``namespace`` that
    answers through the zenoh ``config`` file within ``timeout`` s. ValueError naming ``--config``
    when its router cannot be reached or the file is not a zenoh config."""
    from services.transport import Keyspace, open_session
    from services.transport.about import list_processes

    try:
        with open_session(None, None, None, config, open_timeout=max(timeout, 1.0)) as session:
            return list_processes(session, Keyspace(namespace), timeout)
    except ConnectionError as exc:
        raise ValueError(f"--config {config}: {exc}") from None


def run(args) -> int:
    """Print every running deployment (or the one of ``--namespace``): anchor, launcher pid, state
    directory, and per process its pid, host and health, each problem it reports on a line of
    its own; with ``--config``, every process of ``--namespace`` (default: default) that answers:
    service, host, pid, what it serves, its problems. Exit 0 when everything listed is healthy;
    1 when a process is not, or none runs (none answers)."""
    from services.transport.runfile import running, runtime_dir

    if args.config is not None:
        return _remote(args)
    runs = [r for r in running() if args.namespace is None or r.namespace == args.namespace]
    report = []
    for r in runs:
        procs = process_health(r, args.timeout)
        report.append({"namespace": r.namespace, "anchor": r.anchor, "pid": r.pid, "state_dir": r.state_dir,
                       "secured": bool(r.credentials), "credentials": r.credentials,
                       "processes": [{"name": p.name, "pid": p.pid, "host": p.host, "health": p.health,
                                      "problems": list(p.problems)} for p in procs]})
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
            print(f"  {p['name']:<18} {p['pid']:>7}  {p['host'] or '?':<20} {p['health']}")
            for line in p["problems"]:
                print(f"  {'':<18} {'':>7}  {line}")
    healthy = all(p["health"] == "ok" for d in report for p in d["processes"])
    return 0 if report and healthy else 1


def _remote(args) -> int:
    """``acnmp status --config FILE``: the processes of ``--namespace`` that answer, by host."""
    from dataclasses import asdict

    from services.transport.keys import DEFAULT_NAMESPACE

    namespace = args.namespace or DEFAULT_NAMESPACE
    procs = remote_status(namespace, args.config, args.timeout)
    if args.json:
        print(json.dumps([{"namespace": namespace, "config": args.config,
                           "processes": [asdict(p) for p in procs]}], indent=2))
    elif not procs:
        print(f"no process of deployment {namespace!r} answered through {args.config} within {args.timeout} s",
              file=sys.stderr)
    else:
        print(f"deployment '{namespace}' through {args.config}: {len(procs)} processes on "
              f"{len({p.host for p in procs})} hosts")
        print(f"  {'service':<10} {'host':<20} {'pid':>7}  live as")
        for p in procs:
            print(f"  {p.service:<10} {p.host:<20} {p.pid:>7}  {p.live}")
            for line in p.problems:
                print(f"  {'':<10} {'':<20} {'':>7}  {line}")
    return 0 if procs and not any(p.problems for p in procs) else 1
