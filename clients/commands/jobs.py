"""``acnmp query train|adapt|jobs|watch``: start, list and follow the learner's work from the shell.

``train`` and ``adapt`` change the deployment, so they go with the operator's credentials (as
``cancel`` does); ``jobs`` and ``watch`` only read, with the client's.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time

import numpy as np

from services.transport import jsonable
from services.transport.argtypes import int_at_least, non_empty, seconds

from .common import (_ask, _client, _common, _fail, _floats, _skill, check_condition, condition_arguments, parse_obs,
                     parse_obs_json)

EPILOG = """\
examples:
  acnmp query train --skill reach --demos reach.npz --steps 3000     # blocks until trained
  acnmp query adapt --skill e1 --task viapoint --obs 0:0.0,0.0 --obs 1:1.0,0.0 \\
        --task-params 0.5,0.3 --budget 200 --commit --watch
  acnmp query jobs                                                    # newest first
  acnmp query watch e1-0123456789                                     # until it ends
"""


def add_job_commands(sub) -> None:
    """Add ``train``, ``adapt``, ``jobs`` and ``watch`` to ``acnmp query``'s sub-commands."""
    from acnmp_core.data.demo_io import format_help

    fmt = argparse.RawDescriptionHelpFormatter
    train = sub.add_parser("train", help="train (or retrain) a skill on a demonstrations .npz, on the learner",
                           description="Send a demonstration file to the learner and wait until the skill is "
                                       "trained; the model service then serves the new version. Needs the "
                                       "operator's credentials (found by the run file of `acnmp up`).",
                           epilog=f"{format_help()}\n\n{EPILOG}", formatter_class=fmt)
    _common(train, skill=False)
    train.set_defaults(timeout=600.0)
    train.add_argument("--skill", "-s", required=True, type=non_empty, help="the skill to train")
    train.add_argument("--demos", required=True, metavar="FILE.npz",
                       help="the demonstrations: arrays times (N, T), values (N, T, D), task_params (N, P) (below)")
    train.add_argument("--steps", type=int_at_least(1), default=None, metavar="N",
                       help="training steps (default: the learner's TrainConfig, 5000)")
    train.add_argument("--seed", type=int_at_least(0), default=0, help="training seed (default 0)")
    train.add_argument("--prior", choices=("auto", "trend", "none", "linear"), default=None,
                       help="the model: auto (the default) trend or none, chosen from the demonstrations (held-out "
                            "error at the edges of their conditions; `acnmp query info` says which and why); trend "
                            "the CNMP inside the demonstrations' range and their linear trend beyond it; none the "
                            "paper's CNMP alone; linear the demonstrations' linear path beside the CNMP "
                            "(docs/ALGORITHM.md)")
    train.set_defaults(func=_run_train)

    adapt = sub.add_parser("adapt", help="queue an adaptation job (RL with simultaneous SL) on a skill",
                           description="Queue an adaptation of a skill to new observations / task parameters; "
                                       "prints the job id (follow it with `acnmp query watch`, or --watch). "
                                       "Needs the operator's credentials.",
                           epilog=EPILOG, formatter_class=fmt)
    _common(adapt)
    condition_arguments(adapt, task_params=True, required=True, verb="adapt")
    adapt.add_argument("--task", required=True, type=non_empty,
                       help="the task that scores roll-outs (`acnmp robots` lists each robot's)")
    adapt.add_argument("--robot", default=None, type=non_empty,
                       help="the robot kind whose workers run the roll-outs (default: the kind of the deployment's "
                            "workers, when they are all of one kind)")
    adapt.add_argument("--task-config", metavar="JSON", default=None,
                       help="the task's settings as a JSON object, e.g. for viapoint "
                            "'{\"t_v\": [0.25], \"point\": [[0.25, 0.6]], \"tolerance\": [0.02]}' (the times, "
                            "points and tolerances to pass through; acnmp_core/tasks/registry.py lists each task's)")
    adapt.add_argument("--budget", type=int_at_least(1), default=None, metavar="N",
                       help="roll-out budget (default: AdaptConfig's, 200)")
    adapt.add_argument("--seed", type=int_at_least(0), default=0, help="exploration seed (default 0)")
    adapt.add_argument("--paper", action="store_true",
                       help="the paper's adaptation (AdaptConfig.paper(): each iteration's mean and noisy roll-outs "
                            "as one batch) instead of the default (each mean first; docs/ALGORITHM.md)")
    adapt.add_argument("--commit", action="store_true",
                       help="assimilate a successful solution into the skill (a new version is served)")
    adapt.add_argument("--watch", action="store_true", help="follow the job until it ends (as `watch`)")
    _wait_timeout(adapt, "with --watch: ")
    adapt.set_defaults(func=_run_adapt)

    jobs = sub.add_parser("jobs", help="list the learner's jobs, newest first",
                          description="List the learner's adaptation and paired-training jobs, newest first: "
                                      "state, roll-outs of the budget, success, age.",
                          epilog=EPILOG, formatter_class=fmt)
    _common(jobs, skill=False)
    jobs.add_argument("--limit", type=int_at_least(1, hi=1000), default=20, metavar="N",
                      help="at most N jobs (1..1000, default %(default)s)")
    jobs.set_defaults(func=_run_jobs)

    watch = sub.add_parser("watch", help="follow a job until it ends (progress bar on a terminal)",
                           description="Follow a job: a progress bar of roll-outs on a terminal, one line per "
                                       "change otherwise; at the end its outcome. Exits 0 when the job is done, "
                                       "1 when it failed or was cancelled. While the learner restarts, it waits.",
                           epilog=EPILOG, formatter_class=fmt)
    _common(watch, skill=False)
    watch.add_argument("job", metavar="JOB", help="job id (as `adapt` or `jobs` gave it)")
    _wait_timeout(watch)
    watch.set_defaults(func=_run_watch)


def _wait_timeout(parser, prefix: str = "") -> None:
    parser.add_argument("--wait-timeout", type=seconds(), default=3600.0, metavar="S",
                        help=f"{prefix}give up after S seconds (default: %(default)s)")


def _run_train(args) -> int:
    from acnmp_core.data.demo_io import load_demos

    try:
        arrays = load_demos(args.demos)
    except ValueError as exc:
        raise ValueError(f"--demos {args.demos}: {str(exc).removeprefix('path: ')}") from None
    lengths = np.asarray(arrays.lengths if arrays.lengths is not None else [arrays.values.shape[1]])
    if len(set(lengths.tolist())) > 1:
        raise ValueError(f"--demos {args.demos}: demonstrations of different lengths; a train request takes "
                         "equal lengths (`acnmp up --demos SKILL=FILE.npz` trains any)")
    options = {"seed": args.seed}
    if args.steps is not None:
        options["train"] = {"steps": args.steps}
    if args.prior is not None:
        options["model"] = {"prior": args.prior}
    for key in ("value_names", "task_param_names"):
        names = getattr(arrays, key)
        if names is not None:
            options[key] = [str(n) for n in names]
    tp = arrays.task_params if arrays.task_params.shape[1] else None
    reply, code = _ask(args, lambda client: client.train(args.skill, arrays.times, arrays.values, tp,
                                                         timeout=args.timeout, **options), role="operator")
    if reply is None:
        return code
    print(f"skill {reply['skill']} version {reply['version']}: trained on {reply['n_demos']} demonstrations "
          f"(data hash {reply['data_hash'][:16]})")
    return 0


def _adapt_job(args, client):
    """The :class:`~acnmp_core.jobs.adapt.AdaptJob` of ``args``; the query times from the skill's
    trained time range (its ``info``) unless ``--times`` gives them."""
    from acnmp_core.adaptation.config import AdaptConfig, AdaptTarget
    from acnmp_core.jobs.adapt import AdaptJob

    times, values, mask = parse_obs_json(args.obs_json) if args.obs_json else parse_obs(args.obs)
    query_times = _floats(args.times, "--times")
    task_params = _floats(args.task_params, "--task-params")
    skill = _skill(args, client)
    info = client.info(skill)
    check_condition(skill, info, values, task_params)  # a bad shape is the user's argument: exit 2, nothing queued
    if query_times is None:
        lo, hi = info["time_range"]
        query_times = np.linspace(lo, hi, 100 if args.steps is None else args.steps)
    try:
        task_config = json.loads(args.task_config) if args.task_config else {}
    except json.JSONDecodeError as exc:
        raise ValueError(f"--task-config: not JSON ({exc})") from None
    if not isinstance(task_config, dict):
        raise ValueError("--task-config: expected a JSON object")
    make = AdaptConfig.paper if args.paper else AdaptConfig
    config = make() if args.budget is None else make(max_rollouts=args.budget)
    target = AdaptTarget(times, values, task_params, query_times, None if mask.all() else mask)
    return skill, AdaptJob(target, args.task, _robot(args, client), task_config, config, args.seed, args.commit)


def worker_kinds(client, timeout: float = 2.0) -> list[str]:
    """The robot kinds of the workers ``client``'s deployment runs now (their liveliness tokens
    ``.../worker/<robot>/<id>``), each once, sorted."""
    from services.transport import alive_tokens

    tokens = alive_tokens(client.session, f"{client.keys.prefix}/worker/*/*", timeout)
    return sorted({key.split("/")[-2] for key in tokens})


def _robot(args, client) -> str:
    """``--robot``, or the one robot kind the deployment's workers are of (their liveliness tokens):
    ValueError naming the kinds when they are several, ClientError ``unavailable`` when none is live."""
    from clients.client import ClientError

    if args.robot is not None:
        return args.robot
    kinds = worker_kinds(client)
    if len(kinds) == 1:
        return kinds[0]
    if not kinds:
        raise ClientError("unavailable", "no worker is live in the deployment: give --robot KIND (a job waits "
                                         "for workers of its kind)")
    raise ValueError(f"--robot: the deployment runs workers of {', '.join(kinds)}: choose the kind that runs "
                     f"--task {args.task}")


def _run_adapt(args) -> int:
    from clients.client import ClientError

    with _client(args, role="operator") as client:
        try:
            skill, job = _adapt_job(args, client)
            job_id = client.adapt(skill, job)
        except ClientError as exc:
            return _fail(exc)
        if args.json and not args.watch:
            print(json.dumps({"job": job_id, "skill": skill}))
            return 0
        # with --json (and --watch) stdout holds the final status alone, so a program can parse it
        print(f"job {job_id} queued on skill {skill} ({job.task} on {job.robot}, budget "
              f"{job.config.max_rollouts} roll-outs)" + ("" if args.watch else f"; follow it: acnmp query watch {job_id}"),
              file=sys.stderr if args.json else sys.stdout)
        if not args.watch:
            return 0
        return _follow(args, client, job_id)


def _run_jobs(args) -> int:
    # as maps, so that --json prints them as they are
    rows, code = _ask(args, lambda client: [dataclasses.asdict(r) for r in client.jobs(args.limit)])
    if rows is None:
        return code
    from clients.client import JobSummary  # torch comes with it: not for --help

    rows = [JobSummary.from_reply(r) for r in rows]
    if not rows:
        print("no jobs yet (start one with `acnmp query adapt`)")
        return 0
    now = time.time()
    print(f"{'JOB':<22} {'KIND':<10} {'SKILL':<12} {'TASK':<14} {'STATE':<11} {'ROLL-OUTS':>11} {'SUCCESS':<7} AGE")
    for r in rows:
        used = f"{r.rollouts}/{r.budget}" if r.budget is not None else str(r.rollouts)
        success = "-" if r.success is None else ("yes" if r.success else "no")
        print(f"{r.job:<22} {r.kind:<10} {r.skill:<12} {r.task:<14} {r.state:<11} {used:>11} {success:<7} "
              f"{_age(now - r.created)}")
    return 0


def _run_watch(args) -> int:
    with _client(args) as client:
        return _follow(args, client, args.job)


def _follow(args, client, job_id: str) -> int:
    """Follow ``job_id`` until it ends; print its outcome (or ``--json`` its status). 0 when done."""
    from clients.client import ClientError

    on_terminal = sys.stderr.isatty()
    last = [None]

    def changed(status: dict) -> None:  # without a terminal: one line per state or iteration
        key = (status.get("state"), status.get("iteration"))
        if not on_terminal and key != last[0]:
            last[0] = key
            print(f"job {job_id}: {status.get('state')}, iteration {status.get('iteration')}, "
                  f"{status.get('rollouts')} roll-outs, best return {_num(status.get('best_return'))}",
                  file=sys.stderr, flush=True)
    try:
        status = client.wait_job(job_id, timeout=args.wait_timeout, progress=on_terminal, on_status=changed)
    except ClientError as exc:
        return _fail(exc)
    if args.json:
        print(json.dumps(jsonable(status)))
    else:
        result = status.get("result") or {}
        line = f"job {job_id}: {status['state']}"
        if result:
            line += f", success {result.get('success')}, {result.get('rollouts')} roll-outs"
        if status.get("committed_version") is not None:
            line += f", skill {status['skill']} version {status['committed_version']} holds the solution"
        if status.get("error"):
            line += f" ({status['error']})"
        print(line)
    return 0 if status["state"] == "done" else 1


def _num(value) -> str:
    return "-" if value is None else f"{value:.4g}"


def _age(seconds_ago: float) -> str:
    """``42s``, ``5m``, ``3h``, ``2d``."""
    for unit, size in (("d", 86400), ("h", 3600), ("m", 60)):
        if seconds_ago >= size:
            return f"{int(seconds_ago // size)}{unit}"
    return f"{int(max(seconds_ago, 0))}s"
