"""``acnmp query predict|transfer|info|skills|cancel`` (and ``train|adapt|jobs|watch``, clients/commands/jobs.py):
ask a running deployment from the shell."""
from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from services.transport.argtypes import int_at_least, seconds
from services.transport import SessionOptions, jsonable

#: What ``query`` says when no model service answers its liveliness query.
NO_MODEL_SERVICE = ("no model service is reachable: start one with `acnmp up`, or give the running "
                    "deployment's --namespace or --connect (`acnmp status` lists them)")

EPILOG = """\
examples:
  acnmp query skills                        # the deployment `acnmp up` runs (found by its run file)
  acnmp query skills --namespace lab        # one of several: `acnmp status` lists them
  acnmp query info                          # the deployment's one skill (after `acnmp up`: e1)
  acnmp query info --skill reach
  acnmp query predict --skill reach --obs 0:0.0,0.0 --obs 1:1.0,0.2 --steps 200
  acnmp query predict --skill push --obs 0:0.1,0.2,_ --task-params 0.4,0.3 --times 0,0.5,1 --json
  acnmp query predict --skill reach --obs-json '[[0.0, [0.0, 0.0]]]' --samples 5 --seed 1
  acnmp query transfer --skill e4 --obs 0:0.1,0.5,0.2 --obs 1:0.3,0.4,0.1 --steps 300   # robot A in, B out

An observation is TIME:V1,V2,... with one value per output dimension; write _ for a dimension the
observation does not carry (it is masked out). Without --connect or --config the command finds
the running deployment of --namespace (or the only one running) by the run file `acnmp up`
writes, with its client credentials; $ACNMP_CONNECT (e.g. tcp/127.0.0.1:7447 for the compose
router) skips that.
"""


def register(subparsers) -> None:
    """Add ``query`` with the ``predict``, ``transfer``, ``info``, ``skills`` and ``cancel`` sub-commands."""
    parser = subparsers.add_parser(
        "query", help="ask a running deployment (predict, transfer, info, skills; train, adapt, jobs, watch, cancel)",
        description="Ask a running deployment over zenoh: its model service (predict, transfer, info,\n"
                    "skills) or its learner (train a skill, adapt one, list, follow or cancel jobs).",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="query_command", metavar="WHAT", required=True)

    predict = sub.add_parser("predict", help="condition a skill on observations and predict a trajectory",
                             description="Condition a skill on observations (and task parameters) and print the "
                                         "predicted mean and std per step.",
                             epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    _prediction_arguments(predict, task_params=True)
    predict.set_defaults(func=_run_predict)

    transfer = sub.add_parser("transfer", help="robot B's trajectory for robot A's observations (a paired skill)",
                              description="Encode robot A's observations with a paired skill's encoder A and "
                                          "decode robot B's trajectory with its decoder B (skill transfer); print "
                                          "B's mean and std per step and the latent.",
                              epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    _prediction_arguments(transfer, task_params=False)
    transfer.set_defaults(func=_run_transfer)

    info = sub.add_parser("info", help="describe a served skill (dimensions, names, ranges, version)",
                          description="Describe the model serving a skill.")
    _common(info)
    info.set_defaults(func=_run_info)

    skills = sub.add_parser("skills", help="list the skills some model service has weights for",
                            description="List the skills that have a live model service (liveliness tokens).")
    _common(skills, skill=False)
    skills.set_defaults(func=_run_skills)

    cancel = sub.add_parser("cancel", help="cancel an adaptation job on the learner",
                            description="Cancel a job: a queued one at once, a running one after its current "
                                        "iteration (saved as cancelled). Prints the job's state.")
    _common(cancel, skill=False)
    cancel.add_argument("job", metavar="JOB", help="job id (as the adapt reply gave it)")
    cancel.set_defaults(func=_run_cancel)

    from . import jobs  # train, adapt, jobs, watch: the learner's work

    jobs.add_job_commands(sub)


def condition_arguments(parser: argparse.ArgumentParser, task_params: bool, *, required: bool = False,
                        verb: str = "predict") -> None:
    """``--obs``/``--obs-json`` (one of them; ``required`` or not), ``--task-params`` when
    ``task_params``, ``--steps``/``--times``: the conditioning and the query times of a predict,
    a transfer or an adaptation (``verb`` names it in the help)."""
    what = parser.add_mutually_exclusive_group(required=required)  # --obs-json would silently win over --obs
    what.add_argument("--obs", action="append", default=[], metavar="T:V1,V2,...",
                      help="one observation: time, then a value per output dimension (_ = not observed). Repeatable")
    what.add_argument("--obs-json", metavar="JSON",
                      help='observations as JSON: [[t, [v1, v2, ...]], ...] (null = not observed), or @FILE')
    if task_params:
        parser.add_argument("--task-params", metavar="P1,P2,...", help="task parameters, comma-separated")
    when = parser.add_mutually_exclusive_group()
    when.add_argument("--steps", type=int_at_least(2), default=None, metavar="N",
                      help=f"{verb} at N >= 2 times spread over the trained time range (default: 100)")
    when.add_argument("--times", metavar="T1,T2,...", help=f"{verb} at these times")


def _prediction_arguments(parser: argparse.ArgumentParser, task_params: bool) -> None:
    """The options of ``predict`` and ``transfer``: observations, query times, samples."""
    _common(parser)
    condition_arguments(parser, task_params)
    parser.add_argument("--samples", type=int_at_least(0), default=None, metavar="S",
                        help="also draw S sampled trajectories")
    parser.add_argument("--seed", type=int_at_least(0, hi=2**64 - 1), default=None,  # the wire's uint64
                        help="seed of the samples")


def _common(parser: argparse.ArgumentParser, skill: bool = True) -> None:
    # the same session options as every process (services/transport/session.py); a command has no
    # router role; without --connect it finds the running deployment (clients/discovery.py)
    SessionOptions.add_arguments(parser, modes=("peer", "client"))
    parser.add_argument("--timeout", type=seconds(), default=10.0,
                        help="seconds to wait for a reply (default: %(default)s)")
    parser.add_argument("--json", action="store_true", help="print the full reply as JSON")
    if skill:
        parser.add_argument("--skill", "-s", default=None,
                            help="skill name (default: the deployment's skill, when it serves exactly one)")


def _number(text, where: str) -> float:
    """A finite float from ``text``; ValueError naming ``where`` otherwise."""
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise ValueError(f"{where}: {text!r} is not a finite number")
    return value


def _json_number(value, where: str) -> float:
    """A finite JSON number (not a bool, not a string holding one); ValueError naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{where}: {json.dumps(value)} is not a number")
    return _number(value, where)


def parse_obs(items: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``["t:v1,v2", ...]`` -> times (N,), values (N, D), mask (N, D) bool (False where ``_``).

    ValueError naming the ``--obs`` item for a bad form or a value that is not a finite number."""
    times, rows, masks = [], [], []
    for item in items:
        t, sep, vals = item.partition(":")
        if not sep:
            raise ValueError(f"--obs {item!r}: expected TIME:V1,V2,...")
        parts = [v.strip() for v in vals.split(",")]
        times.append(_number(t, f"--obs {item!r}"))
        rows.append([0.0 if v in ("_", "") else _number(v, f"--obs {item!r}") for v in parts])
        masks.append([v not in ("_", "") for v in parts])
    return _stack_obs(times, rows, masks)


def parse_obs_json(text: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``[[t, [v1, v2|null, ...]], ...]`` (or ``@FILE`` holding it) -> times, values, mask."""
    where = "--obs-json"
    if text.startswith("@"):
        where = f"--obs-json {text}"
        try:
            with open(text[1:], encoding="utf-8") as f:
                text = f.read()
        except OSError as exc:
            raise ValueError(f"{where}: cannot read {text[1:]!r}: {exc.strerror or exc}") from None
        except UnicodeDecodeError:
            raise ValueError(f"{where}: not a UTF-8 text file") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{where}: not JSON ({exc})") from None
    if not isinstance(data, list):
        raise ValueError(f"{where}: expected a list of [t, [values...]]")
    times, rows, masks = [], [], []
    for entry in data:
        if not (isinstance(entry, list) and len(entry) == 2 and isinstance(entry[1], list)):
            raise ValueError(f"{where}: entry {entry!r} is not [t, [values...]]")
        times.append(_json_number(entry[0], where))
        rows.append([0.0 if v is None else _json_number(v, where) for v in entry[1]])
        masks.append([v is not None for v in entry[1]])
    return _stack_obs(times, rows, masks)


def _stack_obs(times, rows, masks):
    if not times:
        raise ValueError("give at least one observation (--obs or --obs-json)")
    if len({len(r) for r in rows}) != 1:
        raise ValueError("every observation needs the same number of values")
    return np.array(times), np.array(rows), np.array(masks, dtype=bool)


def _floats(text: str | None, name: str) -> np.ndarray | None:
    if text is None:
        return None
    parts = [v.strip() for v in text.split(",")]
    if not all(parts):
        raise ValueError(f"{name} {text!r}: an empty entry; expected numbers separated by commas")
    return np.array([_number(v, f"{name} {text!r}") for v in parts])


def _client(args, role: str = "client"):
    from clients.client import ACNMPClient

    opts = SessionOptions.from_args(args)
    # no --connect/--config: the running deployment of --namespace (its run file), with the
    # credentials of ``role``: client (may only ask), or operator for what changes a job
    return ACNMPClient(opts.namespace, connect=opts.connect, mode=opts.mode, listen=opts.listen,
                       config_file=opts.config, timeout=args.timeout, role=role)


def _fail(exc) -> int:
    print(f"acnmp query: {exc.code}: {exc.message}", file=sys.stderr)
    return 1


def _run_predict(args) -> int:
    task_params = _floats(args.task_params, "--task-params")  # refused before any session opens
    return _run_prediction(args, lambda client, skill, **kw: client.predict(skill, task_params=task_params, **kw))


def _run_transfer(args) -> int:
    return _run_prediction(args, lambda client, skill, **kw: client.transfer(skill, **kw))


def _run_prediction(args, ask) -> int:
    """Parse the observations and query times of ``args``, ``ask(client, skill, obs_times=,
    obs_values=, query_times=, n_steps=, obs_dims_mask=, n_samples=, seed=)`` for a
    :class:`~clients.client.PredictResult`, print it (a table, or ``--json``)."""
    from clients.client import ClientError

    if args.obs_json:
        times, values, mask = parse_obs_json(args.obs_json)
    else:
        times, values, mask = parse_obs(args.obs)
    query_times = _floats(args.times, "--times")
    n_steps = None if query_times is not None else (100 if args.steps is None else args.steps)
    with _client(args) as client:
        try:
            p = ask(client, _skill(args, client), obs_times=times, obs_values=values, query_times=query_times,
                    n_steps=n_steps, obs_dims_mask=None if mask.all() else mask, n_samples=args.samples,
                    seed=args.seed)
        except ClientError as exc:
            return _fail(exc)
    if args.json:
        out = {"skill": p.skill, "version": p.version, "times": p.times, "mean": p.mean, "std": p.std,
               "latent": p.latent}
        if p.samples is not None:
            out["samples"] = p.samples
        print(json.dumps(jsonable(out)))
        return 0
    steps, dims = p.mean.shape
    print(f"skill {p.skill} version {p.version}: {steps} steps x {dims} dims (mean ± std); "
          f"latent {p.latent.shape[0]}-D" + (f"; {p.samples.shape[0]} samples (use --json)" if p.samples is not None else ""))
    shown = np.unique(np.linspace(0, steps - 1, min(steps, 11)).round().astype(int))
    for i in shown:
        cells = "  ".join(f"{m:+.4f} ± {s:.4f}" for m, s in zip(p.mean[i], p.std[i]))
        print(f"  t={p.times[i]:<8.4g} {cells}")
    if len(shown) < steps:
        print(f"  ({len(shown)} of {steps} steps shown; --json prints all)")
    return 0


def _skill(args, client) -> str:
    """``--skill``, or the one skill the deployment serves (liveliness tokens); a ClientError
    (``unknown_skill``) naming the choices when none or several are served."""
    from clients.client import ClientError

    if args.skill is not None:
        return args.skill
    names = client.skills()
    if len(names) == 1:
        return names[0]
    if not names and not client.model_services():
        raise ClientError("unavailable", NO_MODEL_SERVICE)
    found = ", ".join(names) if names else "none yet"
    raise ClientError("unknown_skill", f"--skill: choose the skill to ask (served: {found})")


def _ask(args, ask, role: str = "client") -> tuple[dict | None, int]:
    """``ask(client)`` on a client of ``role`` made from ``args``: (reply, 0) for the caller to print;
    (None, exit code) when it is done: an error reply was reported (1) or ``--json`` printed the reply (0)."""
    from clients.client import ClientError

    with _client(args, role) as client:
        try:
            reply = ask(client)
        except ClientError as exc:
            return None, _fail(exc)
    if args.json:
        print(json.dumps(jsonable(reply)))
        return None, 0
    return reply, 0


def _run_info(args) -> int:
    info, code = _ask(args, lambda client: client.info(_skill(args, client)))
    if info is None:
        return code
    print(f"skill {info['skill']} version {info['version']} ({info['source']})")
    print(f"  outputs ({info['n_outputs']}): {', '.join(info['output_names'])}")
    lo, hi = info["value_low"], info["value_high"]
    for name, a, b in zip(info["output_names"], lo, hi):
        print(f"    {name}: demos span [{a:g}, {b:g}]")
    print(f"  task parameters ({info['n_task_params']}): {', '.join(info['task_param_names']) or 'none'}")
    for name, a, b in zip(info["task_param_names"], info["task_param_low"], info["task_param_high"]):
        print(f"    {name}: [{a:g}, {b:g}]")
    print(f"  time range: [{info['time_range'][0]:g}, {info['time_range'][1]:g}]; latent dim {info['latent_dim']}")
    print(f"  trained on {info['n_demos']} demos, data hash {info['data_hash'][:16] or '-'}")
    partner = info.get("partner")
    if partner:
        print(f"  paired skill: `acnmp query transfer` answers robot B's {partner['n_outputs']} outputs "
              f"({', '.join(partner['output_names'])}) for these {info['n_outputs']} of robot A")
    return 0


def _run_skills(args) -> int:
    with _client(args) as client:
        names = client.skills()
        reachable = bool(names) or client.model_services() > 0
    if args.json:
        print(json.dumps(names))
    elif names:
        print("\n".join(names))
    elif reachable:
        print("no skill is served yet (the model service is live, with no weights)")
    else:
        print(f"no skill is served: {NO_MODEL_SERVICE}")
    return 0


def _run_cancel(args) -> int:
    # the router's ACL lets only the operator (and the learner) cancel (docs/PROTOCOL.md, "Security"):
    # with the client's credentials the query is dropped and times out as `unavailable`
    status, code = _ask(args, lambda client: client.cancel(args.job), role="operator")
    if status is None:
        return code
    pending = " (cancel requested: it stops after its current iteration)" if status["state"] == "running" else ""
    print(f"job {status['job']}: {status['state']}{pending}")
    return 0
