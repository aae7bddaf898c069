"""Event messages: what the learner and the experiment runners publish and the recorder writes to the .rrd.

Every event is a wire map (services/transport/wire.py) with ``"v": 1``, ``"kind"`` and ``"t"``
(sender wall time, seconds since the epoch), published on ``acnmp/<ns>/event/<kind>/<id>``
(:meth:`Keyspace.event`; :class:`~services.recording.publisher.EventPublisher` publishes).
The seven kinds and their fields (``?`` marks optional ones; ``T`` steps, ``D`` output dims):

rollout       job str, rollout_index int>=0, trajectory (T,D) float, times (T,) float,
              reward (T,) float (per step), return float, success bool, worker str, host str (optional),
              condition? {times (K,) float, values (K,D) float}, task_params? (P,) float,
              iteration? int, skill? str, space? "cartesian"|"joint",
              drawing? str (a robot drawing kind) with that drawing's fields
latent        skill str, version int, latent (L,) float, label? str, robot? str,
              map_xy? (2,) float (the latent's place in a 2-D map of a version's latents)
model_version skill str, version int, loss? float, n_demos? int, note? str, model? str
job_progress  job str, iteration int, rollouts int, best_return float|None,
              success_rate? float, state? "running"|"done"|"failed"|"cancelled"|"interrupted", skill? str,
              excluded_workers? str (the workers excluded from the job, "<worker>: <why>; ...")
job           job str, method str (e.g. "acnmp", "rl_only", "promp_rl"), robot str, task str,
              skill? str, seed? int, attempt? int, config? str (JSON of the method's settings),
              task_config? str (JSON of the task's parameters), output_names? str (JSON list of
              the skill's D output names), task_param_names? str (JSON list of its P task-parameter
              names): what a job ran, once per attempt
metrics       source str (the skill being trained or the job), phase "train"|"adapt"|"train_pair",
              step int>=0 (training step or adaptation iteration), and one float field per
              metric (e.g. nll, val_nll; mean_return, best_return, explore_std): the learner's
              loss and return curves
process       process str (the launcher's child name), action "restarted"|"gave_up", pid int (the new
              process; the last one for gave_up), exit_code int (negative: killed by that signal),
              restarts int (within the restart window), delay float (s of backoff),
              live_after? float (s from the exit being seen to the new process's liveliness token)

Unknown extra fields are kept (forward compatible) but must be plain scalars or strings.
The builders here validate what they build, so a bad event fails at the sender, and
:func:`validate_event` checks what arrives, so a bad event never reaches the recording. No zenoh
here: the learner core builds events without a session.
"""
from __future__ import annotations

import json
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from acnmp_core.robots.registry import robot
from services.transport.keys import EVENT_KINDS, Keyspace, check_name
from services.transport.wire import WireError, array_field, decode, field, jsonable

#: Per-kind field that names the event's key chunk.
_IDENT_FIELD = {"rollout": "job", "job_progress": "job", "latent": "skill", "model_version": "skill",
                "process": "process", "metrics": "source", "job": "job"}

JOB_STATES = ("running", "done", "failed", "cancelled", "interrupted")
PROCESS_ACTIONS = ("restarted", "gave_up")
METRIC_PHASES = ("train", "adapt", "train_pair")
#: The fields of a metrics event that are not metrics.
METRIC_BASE_FIELDS = ("v", "kind", "t", "source", "phase", "step")

#: Longest trajectory / latent an event may carry; beyond that an event is surely a bug.
MAX_STEPS = 100_000
MAX_DIMS = 64
MAX_LATENT = 4096


def _base(kind: str, t: float | None) -> dict:
    return {"v": 1, "kind": kind, "t": float(time.time() if t is None else t)}


def rollout_event(job: str, rollout_index: int, trajectory, times, reward, *, ret: float | None = None,
                  success: bool = False, worker: str = "", condition: dict | None = None,
                  task_params=None, iteration: int | None = None, skill: str | None = None,
                  space: str = "cartesian", t: float | None = None, host: str = "") -> dict:
    """Build and validate a ``rollout`` event.

    ``trajectory`` (T,D), ``times`` (T,), ``reward`` (T,) per-step rewards; ``ret`` defaults to
    ``reward.sum()``; ``condition`` is ``{"times": (K,), "values": (K,D)}``; ``host``: the worker's
    host (set only when known). Returns the message map.
    """
    reward = np.asarray(reward, dtype=np.float64)
    msg = _base("rollout", t)
    msg.update(job=job, rollout_index=int(rollout_index),
               trajectory=np.asarray(trajectory, dtype=np.float64),
               times=np.asarray(times, dtype=np.float64), reward=reward,
               success=bool(success), worker=str(worker), space=space)
    msg["return"] = float(reward.sum() if ret is None else ret)
    if host:
        msg["host"] = str(host)
    if condition is not None:
        msg["condition"] = {"times": np.asarray(condition["times"], dtype=np.float64),
                            "values": np.asarray(condition["values"], dtype=np.float64)}
    if task_params is not None:
        msg["task_params"] = np.asarray(task_params, dtype=np.float64)
    if iteration is not None:
        msg["iteration"] = int(iteration)
    if skill is not None:
        msg["skill"] = skill
    return validate_event(msg)


def rollout_key(msg: dict) -> str | None:
    """The id of a learner job's roll-out whoever publishes it, ``"rollout/<job>/<rollout_index>"``
    (the shape of an event id, services/recording/event_ids.py): a learner that restarts publishes
    the roll-outs of its journal again, so the recorder keeps such a roll-out once by this id. None
    for any other event, and for roll-outs without ``attempt`` (an experiment's, whose job names a
    later run may use again)."""
    if msg.get("kind") != "rollout" or msg.get("attempt") is None:
        return None
    return f"rollout/{msg['job']}/{int(msg['rollout_index'])}"


def robot_drawing(kind: str):
    """The drawing of robot kind ``kind`` (acnmp_core.robots.registry), or None (draw the path)."""
    return robot(kind).drawing


def batch_rollout_events(job: str, first_index: int, trajectories, times, batch, *,
                         task_params=None, condition: dict | None = None, iteration: int | None = None,
                         skill: str | None = None, drawing=None) -> list[dict]:
    """One validated ``rollout`` event per roll-out of an executed batch, indices from ``first_index``.

    ``trajectories`` (B,T,D) as commanded, ``times`` (T,), ``task_params`` (P,) for all or (B,P) one
    row per roll-out, ``batch`` the RolloutBatch that came back (rewards (B,T), success (B,), states
    {name: (B,T,...)}; the worker of each roll-out from its ``workers``, else ``"local"``). With a
    ``drawing`` (:func:`robot_drawing`) whose first state is in the batch, each event also carries
    ``drawing`` (its kind), the drawing's constant fields and the states it names (e.g. the executed
    ``joint_angles`` and ``object_xy`` of a planar arm), so the recorder draws the robot moving
    through the roll-out; the events' ``space`` is then "joint", else "cartesian".
    """
    trajectories = np.asarray(trajectories, dtype=np.float64)
    workers = getattr(batch, "workers", None) or ("local",) * len(batch)
    hosts = getattr(batch, "hosts", None) or ("",) * len(batch)
    if len(workers) != len(trajectories) or batch.rewards.shape[0] != len(trajectories):
        raise ValueError(f"batch: expected {len(trajectories)} roll-outs, got {len(workers)} worker ids "
                         f"and {batch.rewards.shape[0]} rewards")
    tp = None if task_params is None else np.asarray(task_params, dtype=np.float64)
    if tp is not None and tp.ndim < 2:
        tp = np.broadcast_to(tp.reshape(-1), (len(trajectories), tp.size))
    drawn = drawing is not None and drawing.states[0] in batch.states
    out = []
    for j in range(len(trajectories)):
        ev = rollout_event(job, first_index + j, trajectories[j], times, batch.rewards[j],
                           success=bool(batch.success[j]), worker=str(workers[j]), host=hosts[j], condition=condition,
                           task_params=None if tp is None else tp[j], iteration=iteration, skill=skill,
                           space="cartesian" if drawing is None else "joint")
        if drawn:
            ev.update(drawing.event_fields(), drawing=drawing.kind)
            ev.update({k: np.asarray(batch.states[k][j], dtype=np.float64)
                       for k in drawing.states if k in batch.states})
        out.append(ev)  # rollout_event validated it; the drawing's fields are flat arrays and scalars
    return out


def latent_event(skill: str, version: int, latent, *, label: str | None = None,
                 robot: str | None = None, map_xy=None, t: float | None = None) -> dict:
    """Build and validate a ``latent`` event (one latent vector ``(L,)`` of a skill's encoder);
    ``map_xy`` (2,) places it in a 2-D map of the version's latents (e.g. their first two
    principal components), which the recorder draws as a point."""
    msg = _base("latent", t)
    msg.update(skill=skill, version=int(version), latent=np.asarray(latent, dtype=np.float64).reshape(-1))
    if label is not None:
        msg["label"] = str(label)
    if robot is not None:
        msg["robot"] = str(robot)
    if map_xy is not None:
        msg["map_xy"] = np.asarray(map_xy, dtype=np.float64).reshape(-1)
    return validate_event(msg)


def model_version_event(skill: str, version: int, *, t: float | None = None, **extra: Any) -> dict:
    """Build and validate a ``model_version`` event; ``extra`` adds loss, n_demos, note, ..."""
    msg = _base("model_version", t)
    msg.update(skill=skill, version=int(version), **extra)
    return validate_event(msg)


def job_progress_event(job: str, iteration: int, rollouts: int, best_return: float | None, *,
                       state: str = "running", t: float | None = None, **extra: Any) -> dict:
    """Build and validate a ``job_progress`` event (``best_return`` None before any roll-out)."""
    msg = _base("job_progress", t)
    msg.update(job=job, iteration=int(iteration), rollouts=int(rollouts),
               best_return=None if best_return is None else float(best_return), state=state, **extra)
    return validate_event(msg)


def job_event(job: str, *, method: str, robot: str, task: str, skill: str | None = None, seed: int | None = None,
              attempt: int | None = None, config: dict | None = None, task_config: dict | None = None,
              output_names: Sequence[str] | None = None, task_param_names: Sequence[str] | None = None,
              t: float | None = None) -> dict:
    """Build and validate a ``job`` event: what job ``job`` runs (published before its roll-outs).
    ``config`` and ``task_config`` travel as JSON text (events carry no nested maps), and so do
    ``output_names`` (D,) and ``task_param_names`` (P,), the skill's names of its trajectory's
    columns and of its task parameters, which exports of the roll-outs carry (docs/DATA.md)."""
    msg = _base("job", t)
    msg.update(job=job, method=method, robot=robot, task=task)
    for key, value in (("skill", skill), ("seed", seed), ("attempt", attempt)):
        if value is not None:
            msg[key] = value
    for key, value in (("config", config), ("task_config", task_config)):
        if value is not None:
            msg[key] = json.dumps(jsonable(dict(value)), sort_keys=True)
    for key, names in (("output_names", output_names), ("task_param_names", task_param_names)):
        if names is not None:
            msg[key] = json.dumps([str(n) for n in names])
    return validate_event(msg)


def job_names(msg: dict, key: str) -> list[str] | None:
    """The list of names in field ``key`` (``output_names`` or ``task_param_names``) of a job
    event or of a jobs-table row, None when absent; WireError ``bad_request`` when it is not a
    JSON list of strings."""
    text = msg.get(key)
    if text is None:
        return None
    try:
        names = json.loads(text)
    except (TypeError, ValueError):
        names = None
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise WireError("bad_request", f"field '{key}': expected a JSON list of strings, got {text!r}")
    return names


def metrics_event(source: str, phase: str, step: int, values: dict[str, float], *, t: float | None = None) -> dict:
    """Build and validate a ``metrics`` event: ``values`` ({name: finite float}) of ``source`` (a
    skill or a job) at ``step`` of ``phase``; None values are left out."""
    msg = _base("metrics", t)
    msg.update(source=source, phase=phase, step=int(step))
    for name, value in values.items():
        if name in METRIC_BASE_FIELDS:
            raise ValueError(f"metric name {name!r} clashes with a field of the event")
        if value is not None:
            msg[name] = float(value)
    return validate_event(msg)


def metric_values(msg: dict) -> dict[str, float]:
    """The metrics of a validated ``metrics`` event, by name."""
    return {k: float(v) for k, v in msg.items() if k not in METRIC_BASE_FIELDS and isinstance(v, float)}


def process_event(process: str, action: str, *, pid: int, exit_code: int, restarts: int, delay: float,
                  live_after: float | None = None, t: float | None = None) -> dict:
    """Build and validate a ``process`` event: the launcher restarted a child (or gave up on it)."""
    msg = _base("process", t)
    msg.update(process=process, action=action, pid=int(pid), exit_code=int(exit_code), restarts=int(restarts),
               delay=float(delay))
    if live_after is not None:
        msg["live_after"] = float(live_after)
    return validate_event(msg)


def validate_event(msg: dict) -> dict:
    """Check an event map (built here or decoded from the wire) and return it.

    Raises :class:`WireError` with ``bad_request`` (missing/mistyped field, unknown kind, bad
    name), ``bad_shape``/``bad_dtype`` (arrays) or ``too_large``.
    """
    kind = field(msg, "kind", str)
    if kind not in _IDENT_FIELD:
        raise WireError("bad_request", f"unknown event kind {kind!r}; expected one of {EVENT_KINDS}")
    field(msg, "t", float)
    ident = field(msg, _IDENT_FIELD[kind], str)
    try:
        check_name(_IDENT_FIELD[kind], ident)
    except ValueError as exc:
        raise WireError("bad_request", str(exc)) from None
    if kind == "rollout":
        _validate_rollout(msg)
    elif kind == "latent":
        _nonneg(msg, "version")
        array_field(msg, "latent", ndim=1, max_elements=MAX_LATENT)
        field(msg, "label", str, default=None)
        field(msg, "robot", str, default=None)
        array_field(msg, "map_xy", shape=(2,), default=None)
    elif kind == "model_version":
        _nonneg(msg, "version")
        field(msg, "model", str, default=None)
    elif kind == "job_progress":
        _nonneg(msg, "iteration")
        _nonneg(msg, "rollouts")
        field(msg, "best_return", float, default=None)
        state = field(msg, "state", str, default="running")
        if state not in JOB_STATES:
            raise WireError("bad_request", f"field 'state': {state!r} is not one of {JOB_STATES}")
        field(msg, "excluded_workers", str, default=None)
    elif kind == "job":
        for key in ("method", "robot", "task"):
            field(msg, key, str)
        for key in ("skill", "config", "task_config", "output_names", "task_param_names"):
            field(msg, key, str, default=None)
        for key in ("output_names", "task_param_names"):
            job_names(msg, key)
        for key in ("seed", "attempt"):
            if msg.get(key) is not None:
                _nonneg(msg, key)
    elif kind == "metrics":
        phase = field(msg, "phase", str)
        if phase not in METRIC_PHASES:
            raise WireError("bad_request", f"field 'phase': {phase!r} is not one of {METRIC_PHASES}")
        _nonneg(msg, "step")
        for key, value in msg.items():
            if key not in METRIC_BASE_FIELDS and not (isinstance(value, float) and np.isfinite(value)):
                raise WireError("bad_request", f"metric {key!r}: expected a finite float, got {value!r}")
    elif kind == "process":
        action = field(msg, "action", str)
        if action not in PROCESS_ACTIONS:
            raise WireError("bad_request", f"field 'action': {action!r} is not one of {PROCESS_ACTIONS}")
        field(msg, "pid", int)
        field(msg, "exit_code", int)
        _nonneg(msg, "restarts")
        field(msg, "delay", float)
        field(msg, "live_after", float, default=None)
    for key, value in msg.items():
        if isinstance(value, (dict, list)) and key not in ("condition",):
            raise WireError("bad_request", f"field '{key}': nested values are not allowed in events")
    return msg


def _nonneg(msg: dict, key: str) -> int:
    value = field(msg, key, int)
    if value < 0:
        raise WireError("bad_request", f"field '{key}': must be >= 0, got {value}")
    return value


def _validate_rollout(msg: dict) -> None:
    _nonneg(msg, "rollout_index")
    traj = array_field(msg, "trajectory", ndim=2, max_elements=MAX_STEPS * MAX_DIMS)
    steps, dims = traj.shape
    if steps < 1 or not 1 <= dims <= MAX_DIMS:
        raise WireError("bad_shape", f"field 'trajectory': shape {traj.shape}, need T>=1 and 1<=D<={MAX_DIMS}")
    array_field(msg, "times", shape=(steps,))
    array_field(msg, "reward", shape=(steps,))
    field(msg, "return", float)
    field(msg, "success", bool)
    field(msg, "worker", str)
    field(msg, "host", str, default="")
    space = field(msg, "space", str, default="cartesian")
    if space not in ("cartesian", "joint"):
        raise WireError("bad_request", f"field 'space': {space!r} is not 'cartesian' or 'joint'")
    cond = msg.get("condition")
    if cond is not None:
        if not isinstance(cond, dict):
            raise WireError("bad_request", "field 'condition': expected a map {times, values}")
        ct = array_field(cond, "times", ndim=1, max_elements=MAX_STEPS)
        array_field(cond, "values", shape=(ct.shape[0], dims))
    if msg.get("task_params") is not None:
        array_field(msg, "task_params", ndim=1, max_elements=1024)
    field(msg, "iteration", int, default=None)
    field(msg, "skill", str, default=None)
    field(msg, "drawing", str, default=None)


def event_key(keys: Keyspace, msg: dict) -> str:
    """The key expression an (already validated) event is published on."""
    kind = msg["kind"]
    return keys.event(kind, msg[_IDENT_FIELD[kind]])


def decode_event(payload: bytes) -> dict:
    """Decode and validate one event payload; raises :class:`WireError`."""
    return validate_event(decode(payload))
