"""Turn event maps (services/recording/events.py) into Rerun 0.41 log calls on one recording stream.

No zenoh here: the recorder feeds it from the bus, a notebook or a test can feed it directly.

Entity layout (kind first, then job/skill, because blueprint queries only accept a ``/**`` suffix):

=================================  ==============================  ===========================
entity                             archetype                       from event
=================================  ==============================  ===========================
/trajectory/xy/<job>/path          LineStrips2D (x, y)             rollout, cartesian D=2
/trajectory/xy/<job>/condition     Points2D                        rollout.condition
/trajectory/xyz/<job>/path         LineStrips3D                    rollout, cartesian D=3
/trajectory/xyz/<job>/condition    Points3D                        rollout.condition
/trajectory/time/<job>/path        LineStrips2D (t, y_d) per dim   rollout, joint space or D∉{2,3}
/trajectory/time/<job>/condition   Points2D (t, y_d)               rollout.condition
/arm/<job>/links                   LineStrips3D (base..tip) per    rollout.joint_angles +
                                   control step                    link_lengths (a robot arm)
/arm/<job>/object                  Cylinders3D per control step    rollout.object_xy
/arm/<job>/object_path             LineStrips3D (whole roll-out)   rollout.object_xy
/arm/<job>/target                  Points3D                        rollout.task_params (x, y)
/return/<job>                      Scalars                         rollout.return
/reward/<job>                      BarChart (per-step reward)      rollout.reward
/rollouts/<job>                    AnyValues (index, worker, ...,  rollout (one row each)
                                   event_id, rollout_key; times,
                                   values, reward, task_params at float64)
/jobs/<job>                        AnyValues (method, robot, task, job (once per attempt)
                                   skill, seed, config, names...)
/best_return/<job>                 Scalars                         job_progress
/progress/<job>                    AnyValues                       job_progress
/latent/<skill>/<label>            BarChart                        latent
/latent_map/<skill>/<label>        Points2D (coloured by robot)    latent.map_xy
/models/<skill>                    AnyValues (version, ...)        model_version
/model_version/<skill>             Scalars                         model_version
/log/jobs, /log/models             TextLog                         job_progress, model_version
/metrics/<source>/<phase>/<name>   Scalars (on timeline metric_step) metrics (loss, return curves)
/processes/<name>                  AnyValues (action, pid, ...)    process (a child restarted)
/log/processes                     TextLog                         process
/event_ids/<kind>                  AnyValues (event_id)            every other event the recorder
                                                                   got from an advanced publisher
=================================  ==============================  ===========================

Layout: the blueprint sent with the recording (:func:`default_blueprint`) has the views its
events fill, a left-panel tab being added (the blueprint sent again) when an event first fills it
(:data:`VIEWS`), so a point robot's recording has no empty 3-D tabs.

Timelines: ``rollout`` (sequence: the roll-out index of a rollout event, the roll-out count of a
job_progress event), ``model_version`` (sequence: the version of latent/model_version events) and
``wall_time`` (timestamp: the sender's ``t``); Rerun adds ``log_time`` itself.

Robot roll-outs. A rollout event may carry, besides its trajectory, the executed states of a robot
and the name of its ``drawing`` (acnmp_core/robots/registry.py); services/recording/drawings.py
draws it under ``/arm/<job>``, one frame per control step on the roll-out's own timeline ``step``
(0..T-1), every frame also stamped with ``rollout`` = the roll-out index and ``rollout_step`` =
index * ``STEP_STRIDE`` + step. In the viewer: the ``step`` timeline plays the latest roll-out;
``rollout`` scrubs through the roll-outs (each shown at its final pose, beside its reward);
``rollout_step`` plays them one after another.
"""
from __future__ import annotations

import os
import threading
import uuid
import zlib
from collections import Counter
from collections.abc import Iterable
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from .drawings import drawer_for
from .events import metric_values, rollout_key
from .segments import APPLICATION_ID


#: How many past roll-outs the trajectory views show next to the current one.
TRAIL = 20

_OK = (70, 190, 110)
_FAIL = (215, 80, 60)


#: The tabs of the layout's left panel, in order: each shows what one kind of roll-out (or the
#: paired skills' latents) draws, and a recording has only those its events filled.
VIEWS = ("xy", "time", "xyz", "arm", "poured", "latent_map")


def default_blueprint(views: Iterable[str] = VIEWS) -> rrb.Blueprint:
    """The layout shipped with a recording: the tabs of ``views`` (names of :data:`VIEWS`: a point
    robot's roll-outs fill "xy", an arm's "time" and "arm", the pouring rig's also "poured") beside
    returns (and the learner's metrics), latents, rewards, log."""
    trail = [rrb.VisibleTimeRange("rollout", start=rrb.TimeRangeBoundary.cursor_relative(seq=-TRAIL),
                                  end=rrb.TimeRangeBoundary.cursor_relative())]
    make = {
        "xy": lambda: rrb.Spatial2DView(name="Trajectories (x, y)", origin="/trajectory/xy", time_ranges=trail),
        "time": lambda: rrb.Spatial2DView(name="Trajectories over time", origin="/trajectory/time", time_ranges=trail),
        "xyz": lambda: rrb.Spatial3DView(name="Trajectories (x, y, z)", origin="/trajectory/xyz", time_ranges=trail),
        "arm": lambda: rrb.Spatial3DView(name="Arm and object", origin="/arm"),
        "poured": lambda: rrb.TimeSeriesView(name="Poured (g)", origin="/poured_g"),
        "latent_map": lambda: rrb.Spatial2DView(name="Latent map", origin="/latent_map"),
    }
    right = rrb.Vertical(
        rrb.Tabs(
            rrb.TimeSeriesView(name="Return per roll-out", origin="/", contents=["/return/**", "/best_return/**"]),
            rrb.TimeSeriesView(name="Learner: loss and return", origin="/metrics"),
        ),
        rrb.BarChartView(name="Latent", origin="/latent"),
        rrb.BarChartView(name="Per-step reward", origin="/reward"),
        rrb.TextLogView(name="Models and jobs", origin="/log"),
    )
    left = [make[v]() for v in VIEWS if v in views]
    if not left:  # nothing drawn yet: the curves and the log alone
        return rrb.Blueprint(right, collapse_panels=False)
    return rrb.Blueprint(rrb.Horizontal(rrb.Tabs(*left), right, column_shares=[3, 2]), collapse_panels=False)


#: Colours of the latent map's points, one per robot kind (picked by a stable hash of its name).
_ROBOT_COLORS = ((60, 120, 220), (235, 140, 40), (120, 180, 60), (170, 90, 200))


def _robot_color(robot: str) -> tuple[int, int, int]:
    return _ROBOT_COLORS[zlib.crc32(robot.encode()) % len(_ROBOT_COLORS)]


def _part(name: str) -> str:
    return rr.escape_entity_path_part(str(name))


class RrdWriter:
    """The one writer of an .rrd file: :meth:`log_event` per event, :meth:`close` to finalise.

    Thread-safe (a lock serialises log calls, since Rerun's time cursor is per thread and per
    stream). :meth:`close` flushes and disconnects the file sink, which writes the footer that
    ``rerun rrd verify`` checks; it is idempotent. With ``grpc_port`` the stream is also served
    live over Rerun's gRPC server on ``grpc_bind`` (``grpc_url``: what ``rerun --connect`` takes).
    """

    def __init__(self, path: str | Path, *, application_id: str = APPLICATION_ID,
                 recording_id: str | None = None, blueprint: rrb.Blueprint | None = None,
                 grpc_port: int | None = None, grpc_bind: str = "127.0.0.1"):
        # the layout grows a tab when an event first fills it (the views shown so far), unless the
        # caller gave a layout of its own
        self._views: set[str] | None = None if blueprint is not None else set()
        blueprint = blueprint or default_blueprint(())
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # an explicit RecordingStream (not rr.init): no global state, no viewer spawned, nothing bound
        # live: batches leave every 8 ms (Rerun's low-latency batcher), not every 200 ms (its default),
        # so a viewer sees a roll-out soon after its publication (benchmarks/results/bench_recordings.json)
        self.rec = rr.RecordingStream(application_id, recording_id=recording_id or uuid.uuid4().hex,
                                      batcher_config=rr.ChunkBatcherConfig.LOW_LATENCY() if grpc_port else None)
        if not rr.is_enabled(self.rec):
            # RERUN=off in the environment would make every log call a silent no-op
            raise RuntimeError("Rerun logging is disabled (RERUN=off in the environment): nothing would be recorded")
        # readable by its owner only, like the deployment's secrets (roll-outs, task parameters and
        # weights versions are the user's data): created 0600 before Rerun's sink opens it, which
        # truncates an existing file and keeps its mode
        os.close(os.open(self.path, os.O_WRONLY | os.O_CREAT, 0o600))
        os.chmod(self.path, 0o600)
        self.grpc_url = None
        if grpc_port is None:
            self.rec.save(str(self.path), default_blueprint=blueprint)
        else:
            # live viewing: the same stream also goes to a gRPC server that viewers connect to (it
            # keeps what was logged for viewers that connect late, up to its memory limit)
            self.rec.set_sinks(rr.FileSink(str(self.path)), rr.GrpcServerSink(grpc_bind, int(grpc_port)))
            self.rec.send_blueprint(blueprint, make_active=True, make_default=True)
            self.grpc_url = f"rerun+http://{grpc_bind}:{int(grpc_port)}/proxy"
        self.rec.send_recording_name(f"acnmp {self.path.stem}")
        self.counts: Counter = Counter()
        self.rollouts_per_job: Counter = Counter()
        self._lock = threading.Lock()
        self._closed = False
        self._unflushed: list[str] = []  # roll-out keys logged since the last flush

    # -- dispatch ---------------------------------------------------------------------------

    def log_event(self, msg: dict, event_id: str | None = None) -> None:
        """Log one validated event map (see services/events.py); unknown kinds raise ValueError.

        ``event_id`` (the publisher's id and sequence number, see the recorder) is logged too, under
        ``/event_ids/<kind>``, so a restarted recorder knows which events this file already holds
        (:func:`services.recording.replay.recorded_event_ids`)."""
        kind = msg.get("kind")
        fn = {"rollout": self._rollout, "latent": self._latent, "model_version": self._model_version,
              "job_progress": self._job_progress, "process": self._process, "metrics": self._metrics,
              "job": self._job}.get(kind)
        if fn is None:
            raise ValueError(f"unknown event kind {kind!r}")
        with self._lock:
            if self._closed:
                raise RuntimeError("recording already closed")
            self.rec.reset_time()  # no timeline value leaks from the previous event
            self.rec.set_time("wall_time", timestamp=float(msg["t"]))
            if kind == "rollout":
                # the id goes in the roll-out's own row: the batcher writes entities' chunks in no
                # fixed order, and a recorder killed between an id chunk and its row's chunk made the
                # next recorder skip an event the file lacks (or record one it has, twice)
                fn(msg, event_id)
            else:
                fn(msg)
                if event_id is not None:
                    self.rec.log(f"/event_ids/{kind}", rr.AnyValues(event_id=event_id))
            self.counts[kind] += 1

    def stats(self) -> dict:
        """Counts so far: ``{"events": {kind: n}, "rollouts": {job: n}}``."""
        with self._lock:
            return {"events": dict(self.counts), "rollouts": dict(self.rollouts_per_job)}

    def flush(self, timeout: float = 10.0) -> list[str]:
        """Write everything logged so far into the file (Rerun's batcher otherwise holds it up to
        its flush tick, and a kill -9 loses it); returns the roll-out keys (events.rollout_key)
        logged since the last flush, now in the file. [] once closed."""
        with self._lock:
            if self._closed:
                return []
            keys, self._unflushed = self._unflushed, []
            try:
                self.rec.flush(timeout_sec=timeout)
            except BaseException:
                self._unflushed = keys + self._unflushed
                raise
            return keys

    # -- kinds -------------------------------------------------------------------------------

    def _rollout(self, msg: dict, event_id: str | None = None) -> None:
        job = _part(msg["job"])
        idx = int(msg["rollout_index"])
        self.rec.set_time("rollout", sequence=idx)
        traj = np.asarray(msg["trajectory"], dtype=np.float32)
        times = np.asarray(msg["times"], dtype=np.float32)
        dims = traj.shape[1]
        color = _OK if msg.get("success") else _FAIL
        ret = float(msg["return"])
        label = f"#{idx} R={ret:.3g}"
        cond = msg.get("condition")
        view = _trajectory_view(msg.get("space", "cartesian"), dims)
        if view == "xy":
            self.rec.log(f"trajectory/xy/{job}/path", rr.LineStrips2D([traj], colors=[color], labels=[label]))
            if cond is not None:
                self.rec.log(f"trajectory/xy/{job}/condition",
                             rr.Points2D(np.asarray(cond["values"], np.float32), radii=0.5 * _radius(traj)))
        elif view == "xyz":
            self.rec.log(f"trajectory/xyz/{job}/path", rr.LineStrips3D([traj], colors=[color], labels=[label]))
            if cond is not None:
                self.rec.log(f"trajectory/xyz/{job}/condition",
                             rr.Points3D(np.asarray(cond["values"], np.float32), radii=0.5 * _radius(traj)))
        else:
            # joint space (or an odd dimension count): one (t, y_d) curve per output dimension
            strips = [np.stack([times, traj[:, d]], axis=1) for d in range(dims)]
            self.rec.log(f"trajectory/time/{job}/path",
                         rr.LineStrips2D(strips, labels=[f"y{d}" for d in range(dims)]))
            if cond is not None:
                ct = np.asarray(cond["times"], np.float32)
                cv = np.asarray(cond["values"], np.float32)
                pts = np.concatenate([np.stack([ct, cv[:, d]], axis=1) for d in range(dims)])
                self.rec.log(f"trajectory/time/{job}/condition", rr.Points2D(pts, radii=0.5 * _radius(traj)))
        self.rec.log(f"return/{job}", rr.Scalars(ret))
        self.rec.log(f"reward/{job}", rr.BarChart(np.asarray(msg["reward"], dtype=np.float32)))
        row = dict(rollout_index=idx, worker=str(msg.get("worker", "")), host=str(msg.get("host", "")),
                   success=bool(msg.get("success")),
                   ret=ret, steps=int(traj.shape[0]), iteration=-1 if msg.get("iteration") is None else int(msg["iteration"]),
                   # the data back at full precision (the drawings above are float32): recordings as data
                   dims=int(dims), times=np.asarray(msg["times"], dtype=np.float64),
                   values=np.asarray(msg["trajectory"], dtype=np.float64).reshape(-1),
                   reward=np.asarray(msg["reward"], dtype=np.float64))
        if msg.get("task_params") is not None:
            row["task_params"] = np.asarray(msg["task_params"], dtype=np.float64).reshape(-1)
        for key in ("skill", "attempt", "model_version"):
            if msg.get(key) is not None:
                row[key] = msg[key]
        if event_id is not None:
            row["event_id"] = event_id
        key = rollout_key(msg)
        if key is not None:
            row["rollout_key"] = key
        self.rec.log(f"rollouts/{job}", rr.AnyValues(**row))
        draw = drawer_for(msg)
        if draw is not None:
            draw(self.rec, job, idx, msg, color)
        self._show(view, *(("arm",) if draw is not None else ()),
                   *(("poured",) if draw is not None and msg.get("poured_g_t") is not None else ()))
        self.rollouts_per_job[msg["job"]] += 1
        if key is not None:  # in the file at the next flush
            self._unflushed.append(key)

    def _latent(self, msg: dict) -> None:
        self.rec.set_time("model_version", sequence=int(msg["version"]))
        label = _part(msg.get("label") or "default")
        self.rec.log(f"latent/{_part(msg['skill'])}/{label}",
                     rr.BarChart(np.asarray(msg["latent"], dtype=np.float32)))
        if msg.get("map_xy") is not None:  # one point per latent; colour by robot, so paired latents show as pairs
            self._show("latent_map")
            robot = str(msg.get("robot") or "")
            self.rec.log(f"latent_map/{_part(msg['skill'])}/{label}",
                         rr.Points2D([np.asarray(msg["map_xy"], dtype=np.float32)], radii=0.02,
                                     colors=[_robot_color(robot)], labels=[f"{msg.get('label') or ''} {robot}".strip()]))

    def _model_version(self, msg: dict) -> None:
        skill = _part(msg["skill"])
        version = int(msg["version"])
        self.rec.set_time("model_version", sequence=version)
        extras = {k: v for k, v in msg.items()
                  if k not in ("v", "kind", "t", "skill", "version") and isinstance(v, (int, float, str, bool))}
        self.rec.log(f"models/{skill}", rr.AnyValues(version=version, **{f"x_{k}": v for k, v in extras.items()}))
        self.rec.log(f"model_version/{skill}", rr.Scalars(float(version)))
        detail = " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in extras.items())
        self.rec.log("log/models", rr.TextLog(f"{msg['skill']} v{version} {detail}".strip(), level="INFO"))

    def _job_progress(self, msg: dict) -> None:
        job = _part(msg["job"])
        rollouts = int(msg["rollouts"])
        self.rec.set_time("rollout", sequence=rollouts)
        best = msg.get("best_return")
        state = str(msg.get("state", "running"))
        values = {"iteration": int(msg["iteration"]), "rollouts": rollouts, "state": state}
        if best is not None:
            values["best_return"] = float(best)
            self.rec.log(f"best_return/{job}", rr.Scalars(float(best)))
        excluded = msg.get("excluded_workers")
        if excluded:
            values["excluded_workers"] = str(excluded)
        self.rec.log(f"progress/{job}", rr.AnyValues(**values))
        best_txt = "-" if best is None else f"{best:.4g}"
        level = "ERROR" if state == "failed" else ("WARN" if excluded else "INFO")
        self.rec.log("log/jobs", rr.TextLog(
            f"{msg['job']} it={msg['iteration']} rollouts={rollouts} best={best_txt} {state}"
            + (f"; excluded workers: {excluded}" if excluded else ""), level=level))

    def _job(self, msg: dict) -> None:
        values = {k: msg[k] for k in ("method", "robot", "task", "skill", "config", "task_config", "output_names",
                                      "task_param_names") if msg.get(k) is not None}
        values.update(seed=int(msg.get("seed", -1)), attempt=int(msg.get("attempt", -1)))
        self.rec.log(f"jobs/{_part(msg['job'])}", rr.AnyValues(**values))
        self.rec.log("log/jobs", rr.TextLog(
            f"{msg['job']}: {msg['method']} on {msg['robot']}/{msg['task']}"
            + (f", skill {msg['skill']}" if msg.get("skill") else "")
            + (f", seed {msg['seed']}" if msg.get("seed") is not None else ""), level="INFO"))

    def _metrics(self, msg: dict) -> None:
        self.rec.set_time("metric_step", sequence=int(msg["step"]))
        base = f"metrics/{_part(msg['source'])}/{_part(msg['phase'])}"
        for name, value in metric_values(msg).items():
            self.rec.log(f"{base}/{_part(name)}", rr.Scalars(value))

    def _process(self, msg: dict) -> None:
        name = str(msg["process"])
        live = msg.get("live_after")
        self.rec.log(f"processes/{_part(name)}", rr.AnyValues(
            action=str(msg["action"]), pid=int(msg["pid"]), exit_code=int(msg["exit_code"]),
            restarts=int(msg["restarts"]), delay=float(msg["delay"]), live_after=-1.0 if live is None else float(live)))
        back = "" if live is None else f", live after {float(live):.2f}s"
        self.rec.log("log/processes", rr.TextLog(
            f"{name} {msg['action']} (exit {msg['exit_code']}, restart {msg['restarts']}, pid {msg['pid']}{back})",
            level="ERROR" if msg["action"] == "gave_up" else "WARN"))

    def _show(self, *views: str) -> None:
        """Add the tabs ``views`` to the layout (sent again, made active) when it lacks one."""
        if self._views is None or self._views.issuperset(views):
            return
        self._views.update(views)
        self.rec.send_blueprint(default_blueprint(self._views), make_active=True, make_default=True)

    # -- end ---------------------------------------------------------------------------------

    def close(self, timeout: float = 10.0) -> None:
        """Flush everything and close the file sink so the .rrd gets its footer (idempotent)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            try:
                self.rec.flush(timeout_sec=timeout)
            finally:
                self.rec.disconnect()

    def __enter__(self) -> "RrdWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _trajectory_view(space: str, dims: int) -> str:
    """The tab a roll-out's trajectory is drawn in: a cartesian path of 2 or 3 dimensions as a
    path ("xy", "xyz"), anything else (joint space, other dimension counts) per dimension over
    time ("time")."""
    if space == "cartesian" and dims in (2, 3):
        return "xy" if dims == 2 else "xyz"
    return "time"


def _radius(traj: np.ndarray) -> float:
    """A point radius proportional to the trajectory's extent, so markers are visible at any scale."""
    extent = float(np.ptp(traj, axis=0).max()) if traj.size else 1.0
    return max(extent, 1e-6) * 0.01
