"""``acnmp up``: start a whole local deployment (recorder, learner, model, workers) with no configuration."""
from __future__ import annotations

import os
import sys


#: The learner's options ``acnmp up`` hands on to its learner(s) as they are.
LEARNER_OPTIONS = ("max_queued_jobs", "keep_jobs", "keep_job_days", "keep_versions", "job_runner")


def register(subparsers) -> None:
    """Add the ``up`` sub-command."""
    from services.learner.config import LearnerOptions
    from services.transport.argtypes import int_at_least, key_name, non_empty, robot_help, robot_kind
    from services.transport.service import add_arguments

    import argparse

    from acnmp_core.data.demo_io import format_help

    p = subparsers.add_parser("up", help="start a local deployment on 127.0.0.1 until Ctrl-C / SIGTERM",
                              description=__doc__.splitlines()[0].split(": ", 1)[1], epilog=format_help(),
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--namespace", "-n", type=key_name("namespace"), default="default",
                   help="key prefix acnmp/<namespace>/ (default: %(default)s)")
    p.add_argument("--workers", type=int_at_least(0), default=2, help="number of workers (default: %(default)s)")
    p.add_argument("--robot", default="point2d", type=robot_kind,
                   help=robot_help("robot kind of the workers") + " (default: %(default)s)")
    p.add_argument("--record", type=non_empty, default=None, metavar="FILE.rrd", help="start a recorder writing this file; a recording already there is continued in its next segment, "
                        "FILE.<n>.rrd, never overwritten (`acnmp replay FILE.rrd` reads them together)")
    p.add_argument("--viewer", action="store_true",
                   help="with --record: also stream the recording live (Rerun gRPC server and web viewer, "
                        "both listening on 127.0.0.1 only; the addresses are printed) to watch the deployment "
                        "while it runs (docs/DEPLOYMENT.md, 'Watching it live')")
    p.add_argument("--state-dir", type=non_empty, default=None, metavar="DIR",
                   help="learner checkpoints and process logs, locked while the deployment runs "
                        "(default: the user state directory, ~/.local/state/acnmp/<namespace> on Linux; "
                        "./runs/<namespace>/state, the old default, while only it exists)")
    p.add_argument("--no-model", action="store_true", help="do not start the model service")
    p.add_argument("--model-processes", type=int_at_least(1), default=1, metavar="N",
                   help="model service processes; clients share their predicts between them, so N processes "
                        "use up to N cores (default: %(default)s)")
    p.add_argument("--jobs", type=int_at_least(1), default=None, metavar="N",
                   help="adaptation jobs the learner runs at once (default: the learner's, 2)")
    p.add_argument("--learners", type=int_at_least(1), default=1, metavar="K",
                   help="learner processes; each skill is served by one of them, with its own state directory "
                        "(<state-dir>/learners/<id> beyond the first); keep K for the state directory's life "
                        "(default: %(default)s)")
    p.add_argument("--demos", action="append", default=[], metavar="SKILL=FILE.npz",
                   help="have the learner train SKILL from a demonstration file at start (again when the "
                        "file's demonstrations changed; repeatable); "
                        "without it (and without --no-default-skill) it trains E1's via-point skill 'e1'")
    p.add_argument("--train-steps", type=int_at_least(1), default=None, metavar="N",
                   help="training steps for --demos and the default skill (default: the learner's, 3000)")
    p.add_argument("--no-default-skill", action="store_true",
                   help="do not train and serve E1's via-point skill 'e1' when no --demos is given")
    p.add_argument("--insecure", action="store_true",
                   help="no authentication: a zenoh peer mesh any local process can join (debugging only)")
    add_arguments(p.add_argument_group("the learner's bounds and runner (as `acnmp serve learner`)"),
                  LearnerOptions, only=LEARNER_OPTIONS)
    p.set_defaults(func=run)


def run(args) -> int:
    """Start the deployment (authenticated unless ``--insecure``, announced by its run file; the
    default skill, or every ``--demos`` skill, served first), print what runs where, wait for SIGINT/SIGTERM (restarting children
    that die meanwhile, see services/launcher/supervision.py), stop everything (saying what first);
    run as the ``acnmp`` process itself, end it at once then (:func:`command_owns_the_process`).
    Exit 0; 1 if it could not start (a child that exited first: one line with its last error
    line) or a skill waited for was never served; 2 (ValueError naming
    the option) for a --demos file the learner could not train or a --record file that cannot be
    written or holds something else than an ACNMP recording, before anything starts (an ACNMP
    recording there is continued in its next segment, services/recording/segments.py)."""
    from clients.default_skill import SKILL, default_demos
    from services.launcher import ChildExited, LocalDeployment
    from services.launcher.announce import NamespaceInUse, check_namespace_free
    from services.learner.config import LearnerOptions, absolute_demos_spec, load_demos_spec, parse_demos_spec
    from services.transport.service import handed_on
    from services.transport.state_dir import StateDirInUse
    from services.transport import install_shutdown_handlers
    from services.transport.argtypes import check_output_path
    from services.transport.state_dir import default_state_dir

    for spec in args.demos:  # the learner would exit at its start, be restarted, and exit again
        load_demos_spec(spec)
    # resolved where the user typed them: the learner runs in the project's root
    given = {absolute_demos_spec(spec): spec for spec in args.demos}
    check_output_path(args.record, "--record")  # the recorder would exit before going live
    if args.record:  # an existing recording is continued in a next segment; anything else is refused
        from services.recording.segments import recording_identity, recording_segments

        earlier = recording_segments(args.record)
        if earlier:
            try:
                recording_identity(earlier)
            except ValueError as exc:
                raise ValueError(f"--record {exc}") from None
    if args.viewer and not args.record:
        raise ValueError("--viewer: only with --record FILE.rrd (the viewer shows what the recorder records)")
    try:  # before the default skill's demonstrations are written into the state directory
        check_namespace_free(args.namespace)
    except NamespaceInUse as exc:
        print(f"acnmp up: {exc}", file=sys.stderr)
        return 1
    stop = install_shutdown_handlers()
    state_dir = args.state_dir or str(default_state_dir(args.namespace))
    demos = list(given)
    default_skill = not demos and not args.no_default_skill and not args.no_model
    if default_skill:
        demos.append(default_demos(state_dir))
    learner_args = [a for spec in demos for a in ("--demos", spec)]
    # "up" once the model service serves every skill asked for (it serves what the learner trains)
    waited = [] if args.no_model else [
        (SKILL, "E1's demonstrations at the first start; --no-default-skill skips it") if default_skill else
        (parse_demos_spec(spec), f"{given[spec].partition('=')[2]} at the first start or when it changed")
        for spec in demos]
    if args.train_steps is not None:
        learner_args += ["--train-steps", str(args.train_steps)]
    if args.jobs is not None:
        learner_args += ["--jobs", str(args.jobs)]
    learner_args += handed_on(LearnerOptions, args, LEARNER_OPTIONS)
    served = False
    dep = LocalDeployment(args.namespace, args.workers, args.robot, record=args.record, state_dir=state_dir,
                          model=not args.no_model, learner_args=learner_args, secure=not args.insecure,
                          announce=True, report=report, viewer=args.viewer, model_processes=args.model_processes,
                          learners=args.learners)
    try:
        try:
            dep.start()
        except (StateDirInUse, NamespaceInUse) as exc:  # nothing was started
            print(f"acnmp up: {exc}", file=sys.stderr)
            return 1
        except ChildExited as exc:  # the child's last error line, not the whole tail of its log
            print(f"acnmp up: {str(exc).splitlines()[0]}", file=sys.stderr)
            return 1
        print(dep.describe(), flush=True)
        run = dep.announcement.run
        creds = (f"; credentials: client {run.credentials}, operator {run.operator_credentials}" if dep.secure
                 else "; NOT authenticated (--insecure): any local process can join")
        print(f"run file {run.path} (`acnmp query`, `acnmp status` find it){creds}", flush=True)
        served = all(wait_for_skill(dep, skill, stop, source) for skill, source in waited)
        if served:
            print("deployment is up; Ctrl-C or SIGTERM stops it", flush=True)
            while not stop.wait(0.2):  # the deployment's supervisor restarts (and reports) dead children
                pass
    finally:
        if dep.children:
            print(stopping_line(dep), flush=True)
        codes = dep.stop()
    bad = {n: c for n, c in codes.items() if c != 0}
    if bad:
        print(f"acnmp up: processes ended with errors: {bad}", file=sys.stderr)
    print("deployment stopped: " + " ".join(f"{n}={c}" for n, c in codes.items()), flush=True)
    code = 0 if served or stop.is_set() else 1
    if dep.children and command_owns_the_process():
        # everything it started is stopped and closed: skip the interpreter's teardown (the garbage
        # collection of torch and zenoh takes seconds), as its children do
        import atexit

        from services.transport.lifetime import exit_now

        atexit._run_exitfuncs()
        exit_now(code)
    return code


def command_owns_the_process() -> bool:
    """Whether this process is the ``acnmp`` command itself (the console script or
    ``python -m clients.cli``), not a program calling :func:`clients.cli.main` (a test)."""
    main = sys.modules.get("__main__")
    spec = getattr(main, "__spec__", None)
    return (spec is not None and spec.name == "clients.cli") or \
        os.path.basename(getattr(main, "__file__", "") or "") == "acnmp"


def wait_for_skill(dep, skill: str, stop, source: str, poll: float = 1.0) -> bool:
    """Wait until the model service serves ``skill`` (its liveliness token; the learner trains it
    from ``source``, said in the line printed first). False if stopped, or if the learner or the
    model exited first."""
    from services.transport import wait_for_liveliness

    print(f"waiting for the model service to serve skill {skill!r} (trained from {source})", flush=True)
    while not stop.is_set():
        try:
            wait_for_liveliness(dep.session, dep.keys.model_token(skill), timeout=poll)
            return True
        except TimeoutError:
            # under supervision a dead child is restarted: only one given up on is gone for good
            gone = dep.supervisor.given_up if dep.supervisor is not None else \
                {n for n, c in dep.children.items() if c.proc.poll() is not None}
            dead = [n for n in ("learner", "model") if n in gone]
            if dead:
                print(f"acnmp up: {gone_line(dep, dead, skill)}", file=sys.stderr, flush=True)
                return False
    return False


def gone_line(dep, dead: list[str], skill: str) -> str:
    """The line saying that the children ``dead`` (given up on) exited before serving ``skill``,
    with each one's reason: the last error line of its log, as for a child that never went live."""
    from services.launcher.deployment import last_error_line

    reasons = []
    for name in dead:
        child = dep.children.get(name)
        log = child.log if child is not None else dep.log_dir / f"{name}.log"
        reasons.append(f"{name}: {last_error_line(log) or 'its log says nothing'} (log {log})")
    return f"{' and '.join(dead)} exited before serving {skill!r}; " + "; ".join(reasons)


def stopping_line(dep) -> str:
    """The line ``acnmp up`` prints as it begins to stop ``dep``: what it stops and what is kept."""
    from services.launcher.announce import role_of

    names = list(dep.children)
    workers = sum(n.startswith("worker-") for n in names)
    models = sum(role_of(n) == "model" for n in names)
    parts = [{"learner": "the learner (a running job is saved and resumes at the next start)",
              "model": "the model service" + (f" ({models} processes)" if models > 1 else "")}[n]
             for n in ("learner", "model") if n in names]
    if workers:
        parts.append(f"{workers} worker{'s' if workers != 1 else ''}")
    if "recorder" in names:  # the file it writes now: a continued recording's next segment, a restarted recorder's
        files = dep.recordings or [dep.record]
        merged = f", then merged into {files[0]}" if len(files) > 1 else ""
        parts.append(f"then the recorder (it writes the rest and the footer of {files[-1]}){merged}")
    return (f"acnmp up: stopping deployment {dep.namespace!r}: {', '.join(parts) or 'nothing started'}; "
            f"skills and jobs stay in {dep.state_dir}")


def report(line: str) -> None:
    """One line of the supervisor (a child restarted, live again, given up) on stderr."""
    print(f"acnmp up: {line}", file=sys.stderr, flush=True)
