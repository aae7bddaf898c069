"""What the ``acnmp query`` commands share (clients/commands/query.py and jobs.py): the
conditioning arguments and their parsing, the client a command opens and how it reports failures."""
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


def check_condition(skill: str, info: dict, values: np.ndarray, task_params: np.ndarray | None) -> None:
    """Refuse a conditioning that does not fit the skill ``info`` describes (its info reply) before
    it is sent: ValueError naming the option when the observations (N, D) carry another number of
    values than the skill's outputs, or the task parameters (P,) another number than its own."""
    names = ", ".join(info.get("output_names") or ())
    if values.shape[1] != info["n_outputs"]:
        raise ValueError(f"--obs: {values.shape[1]} values per observation; skill {skill!r} has {info['n_outputs']} "
                         f"outputs ({names}): one value each, _ for one not observed")
    if task_params is not None and len(task_params) != info["n_task_params"]:
        given = ", ".join(info.get("task_param_names") or ()) or "none"
        raise ValueError(f"--task-params: {len(task_params)} values; skill {skill!r} has {info['n_task_params']} "
                         f"task parameters ({given})")


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


def write_demos(output: str, demos, hint: str = "train a skill on it: acnmp up --demos SKILL={path}") -> int:
    """Save ``demos`` (DemoArrays) to ``output`` and print one line saying what was written (the
    values' names when they have some) and ``hint`` (``{path}``: the file written); exit code 0."""
    from acnmp_core.data.demo_io import save_demos

    path = save_demos(output, demos)
    n, t, d = demos.values.shape
    names = "" if demos.value_names is None or not len(demos.value_names) else f" ({', '.join(map(str, demos.value_names))})"
    print(f"wrote {path}: {n} demonstrations of up to {t} steps x {d} dims{names}, {demos.task_params.shape[1]} task "
          f"parameters ({hint.format(path=path)})")
    return 0
