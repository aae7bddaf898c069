"""The learner: owns the skills (CNMP + demonstrations + version), trains them, runs adaptation jobs.

Declared entities (``<ns>`` namespace; docs/PROTOCOL.md has every field):

- queryables ``acnmp/<ns>/skill/*/train`` (train a skill from demonstrations -> new version),
  ``acnmp/<ns>/skill/*/adapt`` (queue an adaptation job -> job id), ``acnmp/<ns>/job/*/status``
  and ``acnmp/<ns>/skill/*/weights/latest`` (a wildcard query gets one reply per skill);
- puts: weights messages on ``acnmp/<ns>/skill/<skill>/weights`` (services/weights_msg.py), and
  events (services/events.py): ``model_version`` per version, per job one ``rollout`` per executed
  trajectory and one ``job_progress`` per iteration;
- liveliness token ``acnmp/<ns>/learner/<id>`` once all of the above exist.

Jobs run one at a time on a background thread: :func:`acnmp_core.adaptation.adapt` on a copy of the
skill's model, with a :class:`~services.remote_evaluator.RemoteEvaluator` over the workers. With
``commit`` a successful solution is assimilated: added to the demonstrations, the model trains on
(``fit_normalization=False``) and a new version is published; without it the skill is unchanged.

Restart (services/jobs.py holds the state): skills reload with their demonstrations (hash-checked);
a job that was running restarts **from its beginning with the same seed** under a new ``attempt``
number (adapt() cannot be resumed mid-way). Roll-out indices stay global over attempts: an
attempt's events continue after the indices the earlier attempts reserved, so a recording never
holds one index twice. Every event of a job carries ``attempt``; the job status reports
``rollouts`` (what the final attempt used) and ``rollouts_executed`` (all attempts). A job whose
adaptation had finished but whose assimilation had not is only re-assimilated (once).
"""
from __future__ import annotations

import argparse
import copy
import dataclasses
import logging
import os
import queue
import sys
import threading
from pathlib import Path
from typing import Callable, Sequence

import numpy as np
import torch
import zenoh

from acnmp_core.adaptation import AdaptConfig, AdaptTarget, adapt
from acnmp_core.cnmp import CNMP, CNMPConfig
from acnmp_core.data import DemoSet, Demonstration
from acnmp_core.demo_io import load_demos
from acnmp_core.tasks.registry import task_names
from acnmp_core.training import TrainConfig, train
from services import keys
from services.events import (
    EventPublisher, arm_drawing, batch_rollout_events, job_progress_event, latent_event, model_version_event,
    validate_event,
)
from services.jobs import UNFINISHED, JobStore, SkillState, SkillStore, new_job
from services.remote_evaluator import RemoteEvaluator
from services.session import (add_session_arguments, declare_rpc, install_shutdown_handlers,
                              open_session, session_kwargs, wait_until_stopped)
from services.weights_msg import encode_weights
from services.wire import WireError, array_field, error_payload, field
from services.worker import ROBOT_TASKS, task_config_for

log = logging.getLogger(__name__)

#: Bound on the demonstrations of one train request (N * T * D values).
MAX_DEMO_VALUES = 10_000_000
#: Model-architecture fields a train request may set (the rest come from the data).
MODEL_FIELDS = ("encoder_widths", "decoder_widths", "std_floor")
TRAIN_FIELDS = tuple(f.name for f in dataclasses.fields(TrainConfig))
ADAPT_FIELDS = tuple(f.name for f in dataclasses.fields(AdaptConfig))
DEFAULT_ASSIMILATE_STEPS = 1000


def _overrides(msg: dict, key: str, allowed: Sequence[str]) -> dict:
    """The map ``msg[key]`` (default {}) checked to hold only ``allowed`` keys of plain values."""
    value = field(msg, key, dict, default={})
    unknown = sorted(set(value) - set(allowed))
    if unknown:
        raise WireError("bad_request", f"field '{key}': unknown setting(s) {unknown}; allowed: {list(allowed)}")
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in value.items()}


def _jsonable(x):
    """Arrays -> nested lists, recursively, so a request can be stored in a JSON job record."""
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    return x


def parse_train_request(msg: dict | None) -> dict:
    """Validate a train request; returns {demos, model_cfg, train_cfg, seed}. Raises WireError.

    Request: ``times`` (N,T) or (T,), ``values`` (N,T,D), ``task_params`` (N,P) optional,
    ``value_names`` (D,) / ``task_param_names`` (P,) optional lists of str, ``model`` (overrides
    of encoder_widths, decoder_widths, std_floor), ``train`` (TrainConfig overrides), ``seed`` int.
    """
    if msg is None:
        raise WireError("bad_request", "a train request needs a payload")
    values = array_field(msg, "values", ndim=3, max_elements=MAX_DEMO_VALUES)
    n, t, d = values.shape
    if n < 1 or t < 2 or d < 1:
        raise WireError("bad_shape", f"field 'values': shape {values.shape}, need N>=1, T>=2, D>=1")
    times = array_field(msg, "times", ndim=(1, 2))
    if times.shape not in ((t,), (n, t)):
        raise WireError("bad_shape", f"field 'times': expected ({t},) or ({n}, {t}), got {times.shape}")
    tp = array_field(msg, "task_params", ndim=2, default=None, max_elements=n * 1024)
    if tp is not None and tp.shape[0] != n:
        raise WireError("bad_shape", f"field 'task_params': expected {n} rows, got {tp.shape[0]}")
    try:
        demos = DemoSet.from_arrays(times, values, tp)
    except ValueError as exc:
        raise WireError("bad_request", f"demonstrations: {exc}") from None
    model_cfg = _overrides(msg, "model", MODEL_FIELDS)
    for key, count in (("value_names", d), ("task_param_names", demos.n_task_params)):
        names = field(msg, key, list, default=None)
        if names is not None:
            if len(names) != count or not all(isinstance(s, str) for s in names):
                raise WireError("bad_request", f"field '{key}': expected {count} strings")
            model_cfg["output_names" if key == "value_names" else key] = names
    try:
        cnmp_cfg = CNMPConfig(n_outputs=d, n_task_params=demos.n_task_params, **model_cfg)
        train_cfg = TrainConfig(**_overrides(msg, "train", TRAIN_FIELDS))
    except (TypeError, ValueError) as exc:
        raise WireError("bad_request", f"settings: {exc}") from None
    if train_cfg.max_obs + 1 > t:
        raise WireError("bad_request", f"train.max_obs: demonstrations of {t} points need max_obs < {t}")
    return {"demos": demos, "model_cfg": cnmp_cfg, "train_cfg": train_cfg, "seed": field(msg, "seed", int, default=0)}


class Learner:
    """The learner's state and handlers on an open session; :meth:`close` stops it.

    Parameters
    ----------
    session : open zenoh session (closed by the caller after :meth:`close`).
    namespace : deployment namespace. state_dir : where skills and jobs are checkpointed.
    learner_id : liveliness id. wait_recorder : seconds to wait for a recorder before the first
        event (0: do not wait; events published with no recorder are simply not recorded).
    chunk_timeout : seconds a worker may take for its share of a batch before it is re-sent.
    """

    def __init__(self, session: zenoh.Session, namespace: str, state_dir: str | os.PathLike, *,
                 learner_id: str | None = None, wait_recorder: float = 0.0, chunk_timeout: float = 60.0):
        self.session = session
        self.ns = keys.check_name("namespace", namespace)
        self.learner_id = keys.check_name("learner id", learner_id or f"learner-{os.getpid()}")
        self.skill_store = SkillStore(state_dir)
        self.job_store = JobStore(state_dir)
        self.events = EventPublisher(session, self.ns)
        self.wait_recorder = float(wait_recorder)
        self.chunk_timeout = float(chunk_timeout)
        self._recorder_checked = wait_recorder <= 0
        self._lock = threading.RLock()  # guards skills and jobs
        self._train_lock = threading.Lock()  # one training at a time (the machine has few cores)
        self.skills: dict[str, SkillState] = self.skill_store.load_all()
        self.jobs: dict[str, dict] = self.job_store.load_all()
        self._queue: queue.Queue = queue.Queue()
        self._stop = threading.Event()
        for job in self.jobs.values():
            if job["state"] in UNFINISHED:
                if job["state"] == "running":  # interrupted: restart under a new attempt number
                    job["attempt"] += 1
                    job["state"] = "queued"
                    self.job_store.save(job)
                self._queue.put(job["job"])
        self._rpcs = [
            declare_rpc(session, keys.skill_any_key(self.ns, "train"), self._handle_train, workers=1),
            declare_rpc(session, keys.skill_any_key(self.ns, "adapt"), self._handle_adapt, workers=1),
            declare_rpc(session, keys.job_status_pattern(self.ns), self._handle_status, workers=1),
        ]
        self._latest = session.declare_queryable(keys.skill_any_key(self.ns, "weights", "latest"),
                                                 self._handle_latest)
        self._thread = threading.Thread(target=self._job_loop, name="jobs", daemon=True)
        self._thread.start()
        self.token_key = keys.learner_token_key(self.ns, self.learner_id)
        self._token = session.liveliness().declare_token(self.token_key)

    # ----- skills ----------------------------------------------------------------------------
    def train_skill(self, skill: str, parsed: dict) -> SkillState:
        """Train a new model for ``skill`` on ``parsed`` (:func:`parse_train_request`), save and publish it."""
        model = CNMP(parsed["model_cfg"], seed=parsed["seed"])
        with self._train_lock:
            res = train(model, parsed["demos"], parsed["train_cfg"], seed=parsed["seed"], progress=False)
        with self._lock:
            old = self.skills.get(skill)
            state = SkillState(skill, model, parsed["demos"], 0 if old is None else old.version + 1)
            self._commit_skill(state, loss=res.best_val, note="trained")
        return state

    def _commit_skill(self, state: SkillState, **extra) -> None:
        # checkpoint first (a published version must survive a crash), then announce it
        self.skill_store.save(state)
        self.skills[state.name] = state
        self.session.put(keys.skill_weights_key(self.ns, state.name),
                         encode_weights(state.name, state.version, state.model,
                                        data_hash=state.demos.content_hash(), n_demos=len(state.demos)),
                         congestion_control=zenoh.CongestionControl.BLOCK)
        self._publish(model_version_event(state.name, state.version, n_demos=len(state.demos),
                                          **{k: v for k, v in extra.items() if v is not None}))
        # The latent of every demonstration under this version, for the recording's latent view.
        for i, demo in enumerate(state.demos):
            latent = state.model.encode_demo(demo.times, demo.values, demo.task_params)
            self._publish(latent_event(state.name, state.version, latent, label=f"demo{i}"))
        log.info("skill %s: version %d (%d demos)", state.name, state.version, len(state.demos))

    def _publish(self, event: dict) -> None:
        if not self._recorder_checked:
            self._recorder_checked = True
            if not self.events.wait_for_recorder(self.wait_recorder):
                log.warning("no recorder live after %.0fs: events are not recorded", self.wait_recorder)
        self.events.publish(event)

    def _skill_of(self, query: zenoh.Query, msg: dict | None = None) -> str:
        try:
            skill = keys.skill_from_key(str(query.key_expr))
        except ValueError as exc:
            raise WireError("bad_request", str(exc)) from None
        if msg is not None and msg.get("skill") not in (None, skill):
            raise WireError("bad_request", f"field 'skill': {msg['skill']!r} differs from the key's {skill!r}")
        return skill

    # ----- handlers --------------------------------------------------------------------------
    def _handle_train(self, msg: dict | None, query: zenoh.Query) -> dict:
        skill = self._skill_of(query, msg)
        state = self.train_skill(skill, parse_train_request(msg))
        return {"v": 1, "skill": skill, "version": state.version, "data_hash": state.demos.content_hash(),
                "n_demos": len(state.demos)}

    def _handle_adapt(self, msg: dict | None, query: zenoh.Query) -> dict:
        skill = self._skill_of(query, msg)
        job = self.submit(skill, msg)
        return {"v": 1, "job": job["job"], "skill": skill, "state": job["state"]}

    def _handle_status(self, _msg, query: zenoh.Query) -> dict:
        try:
            job_id = keys.job_from_key(str(query.key_expr))
        except ValueError as exc:
            raise WireError("bad_request", str(exc)) from None
        return self.status(job_id)

    def _handle_latest(self, query: zenoh.Query) -> None:
        # hand-written (not declare_rpc): a wildcard query, as the model service sends at start,
        # gets one reply per skill on that skill's concrete key
        with query:
            try:
                chunk = str(query.key_expr).split("/")[3]
                with self._lock:
                    if "*" in chunk:
                        states = list(self.skills.values())
                    elif chunk in self.skills:
                        states = [self.skills[chunk]]
                    else:
                        query.reply_err(error_payload("unknown_skill", f"no skill {chunk!r} on this learner"))
                        return
                    bodies = [(s.name, encode_weights(s.name, s.version, s.model, data_hash=s.demos.content_hash(),
                                                      n_demos=len(s.demos))) for s in states]
                for name, body in bodies:
                    query.reply(keys.skill_weights_latest_key(self.ns, name), body)
            except Exception as exc:
                log.exception("weights/latest failed")
                query.reply_err(error_payload("internal", f"{type(exc).__name__}: {exc}"))

    # ----- jobs ------------------------------------------------------------------------------
    def submit(self, skill: str, msg: dict | None) -> dict:
        """Validate an adaptation request for ``skill`` and queue a job; returns the job record.

        Raises WireError: ``unknown_skill``, ``unknown_task``, ``bad_request``/``bad_shape``.
        """
        if msg is None:
            raise WireError("bad_request", "an adapt request needs a payload")
        with self._lock:
            if skill not in self.skills:
                raise WireError("unknown_skill", f"no skill {skill!r}; train it first")
            model = self.skills[skill].model
        target = field(msg, "target", dict)
        obs_t = array_field(target, "obs_times", ndim=1, max_elements=10_000)
        obs_v = array_field(target, "obs_values", ndim=2, max_elements=1_000_000)
        tp = array_field(target, "task_params", ndim=1, default=None, max_elements=1024)
        q_t = array_field(target, "query_times", ndim=1, max_elements=100_000)
        task = field(msg, "task", str)
        if task not in task_names():
            raise WireError("unknown_task", f"task {task!r} is not registered; known: {task_names()}")
        robot = field(msg, "robot", str, default="point2d")
        if robot not in ROBOT_TASKS:
            raise WireError("bad_request", f"field 'robot': {robot!r} is not one of {list(ROBOT_TASKS)}")
        task_config = task_config_for(robot, task, field(msg, "task_config", dict, default={}))
        cfg = _overrides(msg, "config", ADAPT_FIELDS)
        try:
            AdaptConfig(**cfg)
            AdaptTarget(obs_t, obs_v, tp, q_t).query(model)
        except (TypeError, ValueError) as exc:
            raise WireError("bad_request", str(exc)) from None
        request = _jsonable({
            "target": {"obs_times": obs_t, "obs_values": obs_v, "task_params": tp, "query_times": q_t},
            "task": task, "task_config": task_config, "robot": robot, "config": cfg,
            "seed": field(msg, "seed", int, default=0), "commit": field(msg, "commit", bool, default=False),
            "assimilate_steps": field(msg, "assimilate_steps", int, default=DEFAULT_ASSIMILATE_STEPS),
        })
        job = new_job(skill, request)
        with self._lock:
            self.jobs[job["job"]] = job
            self.job_store.save(job)
        self._queue.put(job["job"])
        return job

    def status(self, job_id: str) -> dict:
        """The status reply of job ``job_id`` (see docs/PROTOCOL.md); WireError ``unknown_job``."""
        with self._lock:
            job = self.jobs.get(job_id)
            if job is None:
                raise WireError("unknown_job", f"no job {job_id!r}")
            job = copy.deepcopy(job)
        req = job["request"]
        out = {"v": 1, "job": job["job"], "skill": job["skill"], "state": job["state"], "attempt": job["attempt"],
               "iteration": job["iteration"], "rollouts": job["rollouts"], "rollouts_executed": job["next_index"],
               "best_return": job["best_return"], "error": job["error"], "committed_version": job["committed_version"],
               "task": req["task"], "robot": req["robot"], "commit": req["commit"], "result": None}
        if job["result"] is not None:
            r = job["result"]
            out["result"] = {"success": r["success"], "rollouts": r["rollouts"],
                             "trajectory": np.asarray(r["trajectory"]), "times": np.asarray(r["times"]),
                             "history": r["history"]}
        return out

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Block until no job is queued or running (True), or ``timeout`` passes (False). For tests."""
        import time

        end = None if timeout is None else time.monotonic() + timeout
        while True:
            with self._lock:
                if all(j["state"] not in UNFINISHED for j in self.jobs.values()):
                    return True
            if end is not None and time.monotonic() > end:
                return False
            time.sleep(0.05)

    def _job_loop(self) -> None:
        torch.set_num_threads(1)
        while not self._stop.is_set():
            try:
                job_id = self._queue.get(timeout=0.2)
            except queue.Empty:
                continue
            try:
                self._run_job(job_id)
            except InterruptedError:  # shutting down: the record stays "running", a restart resumes it
                log.info("job %s interrupted by shutdown", job_id)
                return
            except Exception as exc:  # a job failure must not stop the loop
                log.exception("job %s failed", job_id)
                with self._lock:
                    job = self.jobs[job_id]
                    job["state"], job["error"] = "failed", f"{type(exc).__name__}: {exc}"
                    self.job_store.save(job)
                self._safe_progress(job, "failed")

    def _safe_progress(self, job: dict, state: str) -> None:
        try:
            self._publish(self._progress_event(job, state))
        except Exception:
            log.exception("could not publish progress of %s", job["job"])

    def _progress_event(self, job: dict, state: str) -> dict:
        ev = job_progress_event(job["job"], job["iteration"], job["rollouts"], job["best_return"], state=state,
                                skill=job["skill"])
        ev["attempt"] = int(job["attempt"])
        return validate_event(ev)

    def _run_job(self, job_id: str) -> None:
        with self._lock:
            job = self.jobs[job_id]
            if self._stop.is_set() or job["state"] not in UNFINISHED:
                return
            req = job["request"]
            skill = self.skills[job["skill"]]
            model, demos, start_version = copy.deepcopy(skill.model), skill.demos, skill.version
            job["state"] = "running"
            job["attempt_start_index"] = job["next_index"]
            self.job_store.save(job)
        tg = req["target"]
        tp = None if tg["task_params"] is None else np.asarray(tg["task_params"], dtype=np.float64)
        target = AdaptTarget(np.asarray(tg["obs_times"], dtype=np.float64), np.asarray(tg["obs_values"], dtype=np.float64),
                             tp, np.asarray(tg["query_times"], dtype=np.float64))
        if job["result"] is None:
            evaluator = RemoteEvaluator(self.session, self.ns, req["robot"], req["task"], req["task_config"],
                                        timeout=self.chunk_timeout)
            arm = arm_drawing(req["robot"])
            condition = {"times": target.obs_times, "values": target.obs_values}

            def on_iteration(it_log, trajectories, batch) -> None:
                if self._stop.is_set():
                    raise InterruptedError("learner is shutting down")
                b = len(batch)
                with self._lock:
                    first = job["next_index"]
                    job["next_index"] += b  # reserve the indices before any event names them
                    job["iteration"] = it_log.iteration
                    job["rollouts"] = it_log.rollouts
                    best = float(np.max(batch.returns))
                    job["best_return"] = best if job["best_return"] is None else max(job["best_return"], best)
                    self.job_store.save(job)
                for ev in batch_rollout_events(job["job"], first, trajectories, target.query_times, batch,
                                               evaluator.last_workers, task_params=tp,
                                               condition=condition if arm is None else None,
                                               iteration=it_log.iteration, skill=job["skill"], arm=arm):
                    ev["attempt"] = int(job["attempt"])
                    self._publish(ev)
                self._publish(self._progress_event(job, "running"))

            res = adapt(model, demos, target, evaluator, AdaptConfig(**req["config"]), seed=req["seed"],
                        on_iteration=on_iteration)
            with self._lock:
                job["rollouts"] = res.rollouts
                job["result"] = {"success": bool(res.success), "rollouts": int(res.rollouts),
                                 "trajectory": res.trajectory.tolist(), "times": res.times.tolist(),
                                 "history": [{"iteration": h.iteration, "rollouts": h.rollouts,
                                              "mean_return": h.mean_return, "mean_success": h.mean_success}
                                             for h in res.history]}
                self.job_store.save(job)  # adaptation done: a crash from here on only re-assimilates
        result = job["result"]
        if req["commit"] and result["success"]:
            self._assimilate(job, model if skill.version == start_version else None, target, tp)
        with self._lock:
            job["state"] = "done"
            self.job_store.save(job)
        self._publish(self._progress_event(job, "done"))

    def _assimilate(self, job: dict, adapted: CNMP | None, target: AdaptTarget, tp) -> None:
        """Add the job's solution to the skill's demos, train on, publish a new version (once)."""
        res, req = job["result"], job["request"]
        traj, times = np.asarray(res["trajectory"]), np.asarray(res["times"])
        with self._lock:
            skill = self.skills[job["skill"]]
            last = skill.demos[len(skill.demos) - 1]
            if last.values.shape == traj.shape and np.array_equal(last.values, traj) \
                    and np.array_equal(last.times, times):
                job["committed_version"] = skill.version  # committed before a crash; do not add it twice
                return
            # the adapted copy found the solution; if the skill changed meanwhile, train the new one
            model = adapted if adapted is not None and job.get("result") else copy.deepcopy(skill.model)
            params = np.zeros(skill.demos.n_task_params) if tp is None else tp
            demos = skill.demos.added(Demonstration(times, traj, params))
        with self._train_lock:
            train(model, demos, TrainConfig(steps=int(req["assimilate_steps"])), seed=int(req["seed"]) + 1,
                  fit_normalization=False, progress=False)
        with self._lock:
            state = SkillState(skill.name, model, demos, self.skills[skill.name].version + 1)
            self._commit_skill(state, note=f"assimilated {job['job']}")
            job["committed_version"] = state.version
            self.job_store.save(job)

    def close(self) -> None:
        """Stop taking requests, interrupt the running job (it resumes on restart), undeclare all."""
        self._stop.set()
        try:
            self._token.undeclare()
        except Exception:
            pass
        for rpc in self._rpcs:
            rpc.close()
        try:
            self._latest.undeclare()
        except Exception:
            pass
        self._thread.join(timeout=10)

    def __enter__(self) -> "Learner":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _bootstrap(learner: Learner, specs: Sequence[str], steps: int) -> None:
    """Train ``SKILL=FILE.npz`` demonstration files that are not skills yet (``--demos``)."""
    for spec in specs:
        if "=" not in spec:
            raise ValueError(f"--demos: expected SKILL=FILE.npz, got {spec!r}")
        name, path = spec.split("=", 1)
        keys.check_name("skill", name)
        if name in learner.skills:
            continue
        arrays = load_demos(path)
        demos = arrays.to_demo_set()
        cfg = CNMPConfig(n_outputs=demos.n_outputs, n_task_params=demos.n_task_params,
                         output_names=() if arrays.value_names is None else tuple(arrays.value_names),
                         task_param_names=() if arrays.task_param_names is None else tuple(arrays.task_param_names))
        learner.train_skill(name, {"demos": demos, "model_cfg": cfg, "train_cfg": TrainConfig(steps=steps), "seed": 0})


def run(namespace: str = keys.DEFAULT_NAMESPACE, state_dir: str | os.PathLike = "runs/state", *,
        learner_id: str | None = None, wait_recorder: float = 0.0, demos: Sequence[str] = (),
        train_steps: int = 3000, chunk_timeout: float = 60.0, mode: str | None = "peer",
        listen: Sequence[str] | None = None, connect: Sequence[str] | None = None, config_file: str | None = None,
        stop: threading.Event | None = None, ready: Callable[[Learner], None] | None = None) -> int:
    """Run the learner until ``stop`` is set (default: SIGTERM/SIGINT); return exit code 0."""
    if stop is None:
        stop = install_shutdown_handlers()
    torch.set_num_threads(1)
    with open_session(mode, listen, connect, config_file) as session:
        with Learner(session, namespace, state_dir, learner_id=learner_id, wait_recorder=wait_recorder,
                     chunk_timeout=chunk_timeout) as learner:
            _bootstrap(learner, demos, train_steps)
            if ready is not None:
                ready(learner)
            wait_until_stopped(stop)
    return 0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the learner's options and the shared session options."""
    parser.add_argument("--state-dir", default="runs/state", metavar="DIR",
                        help="checkpoints of skills and jobs (default: %(default)s)")
    parser.add_argument("--id", default=None, help="learner id (default: learner-<pid>)")
    parser.add_argument("--demos", action="append", default=[], metavar="SKILL=FILE.npz",
                        help="train SKILL from a demonstration file at start unless it exists (repeatable)")
    parser.add_argument("--train-steps", type=int, default=3000, help="steps for --demos (default: %(default)s)")
    parser.add_argument("--wait-recorder", type=float, default=0.0, metavar="S",
                        help="wait up to S seconds for a recorder before the first event (default: 0)")
    parser.add_argument("--chunk-timeout", type=float, default=60.0, metavar="S",
                        help="seconds a worker may take for its share of a batch (default: %(default)s)")
    add_session_arguments(parser)


def run_from_args(args: argparse.Namespace) -> int:
    """Run with options parsed by :func:`add_arguments`."""
    def ready(learner: Learner) -> None:
        print(f"learner live as {learner.token_key}; skills: {sorted(learner.skills) or 'none yet'}; "
              f"state in {Path(args.state_dir).resolve()}", flush=True)

    return run(args.namespace, args.state_dir, learner_id=args.id, wait_recorder=args.wait_recorder,
               demos=args.demos, train_steps=args.train_steps, chunk_timeout=args.chunk_timeout,
               ready=ready, **session_kwargs(args))


def main(argv: list[str] | None = None) -> int:
    """``python -m services.learner [--state-dir DIR] [--namespace NS] [--connect EP] ...``."""
    parser = argparse.ArgumentParser(prog="acnmp serve learner", description=__doc__.splitlines()[0])
    add_arguments(parser)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s learner %(levelname)s %(message)s")
    return run_from_args(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
