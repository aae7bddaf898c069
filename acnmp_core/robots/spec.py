"""The types that describe a robot kind, apart from the registry that holds them.

A plugin (a robot from another package, see :mod:`acnmp_core.robots.plugins`) imports these and
nothing else of the library's robots: :class:`RobotSpec` (a kind, its tasks, its body loaded on
first use), :class:`RobotBody` (joints, drawing, simulator), :class:`Joint`, :class:`TaskFactory`
(a task the robot brings) and the drawings.

Drawings
--------
A drawing is a small frozen dataclass with a ``kind`` (the recorder's dispatch key), ``states``
(the names of the :class:`~acnmp_core.rollout.RolloutBatch` states it needs from each roll-out)
and ``event_fields()`` (constant fields, e.g. link lengths, that travel with each roll-out event).
:class:`PlanarChainDrawing` draws a planar arm as a line strip from its joint angles; a mesh robot
names its URDF and joints (its drawer logs the meshes once and a transform per link and step), a
set of points (the pouring rig's marbles) names the state holding their positions, and any robot
that reports its end effector's path can use :class:`EndEffectorPathDrawing` (with the task's
points, a via-point and a goal, as :class:`DrawnTarget`). The recorder
(``services/recording/drawings.py``) holds one drawing function per kind.
"""
from __future__ import annotations

import functools
import json
import re
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, ClassVar, Mapping

import numpy as np

from ..errors import InputError, UnknownTaskError
from ..rollout import RolloutEvaluator

#: A robot kind is one key chunk on the wire and a command-line word.
_KIND = re.compile(r"[A-Za-z][A-Za-z0-9_-]{0,39}")


@dataclass(frozen=True)
class TaskFactory:
    """A task a robot brings with it: ``build(params: dict) -> RolloutEvaluator`` and its credit
    for :func:`~acnmp_core.adaptation.loop.adapt` ("step": each step's reward is credited to that step;
    "future": to every earlier step, for rewards that come late, e.g. pushes)."""

    build: Callable[[dict], RolloutEvaluator]
    credit: str = "step"

    def __post_init__(self) -> None:
        if not callable(self.build):
            raise InputError(f"build: expected a function params -> RolloutEvaluator, got {type(self.build).__name__}")
        if self.credit not in ("step", "future"):
            raise InputError(f"credit: expected 'step' or 'future', got {self.credit!r}")


#: A drawn target's name: what the recording labels it with (and its entity's last part).
_TARGET_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9 _-]{0,39}")


@dataclass(frozen=True)
class DrawnTarget:
    """A point of the task drawn with each roll-out, e.g. a via-point or the goal: ``name`` (its
    label) and ``params``, the indices of its x, y[, z] (m) in the task parameters. A target of
    two indices is drawn at the height of the path's first point."""

    name: str
    params: tuple[int, ...]

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _TARGET_NAME.fullmatch(self.name):
            raise InputError(f"targets: a target's name is 1-40 letters, digits, spaces, '_' or '-', got {self.name!r}")
        params = tuple(self.params) if isinstance(self.params, (tuple, list)) else ()
        if len(params) not in (2, 3) or not all(isinstance(i, int) and not isinstance(i, bool) and i >= 0
                                                for i in params):
            raise InputError(f"targets.{self.name}: expected the indices of x, y[, z] in the task parameters "
                             f"(2 or 3 integers >= 0), got {self.params!r}")
        object.__setattr__(self, "params", params)


@dataclass(frozen=True)
class EndEffectorPathDrawing:
    """Draw a roll-out as the path of the robot's end effector, ``ee_xyz`` (T, 3) m, and, when the
    roll-out has it, a handled object's path ``object_xyz`` (T, 3) m; the task's points are drawn
    as labelled targets: ``goal_params`` (indices of x, y[, z] in the task parameters, m) as the
    one named "goal", and each of ``targets`` (:class:`DrawnTarget`, e.g. a via-point and a
    goal). The drawing any robot can have (e.g. a Gymnasium environment's, see
    :mod:`acnmp_core.robots.gym_robot`)."""

    kind: ClassVar[str] = "ee_path"
    #: roll-out states this drawing reads (the first is required, the others optional)
    states: ClassVar[tuple[str, ...]] = ("ee_xyz", "object_xyz")

    goal_params: tuple[int, ...] = ()
    targets: tuple[DrawnTarget, ...] = ()

    def __post_init__(self) -> None:
        targets = tuple(self.targets)
        if not all(isinstance(t, DrawnTarget) for t in targets):
            raise InputError("targets: expected DrawnTarget(name, params) entries")
        object.__setattr__(self, "targets", targets)
        names = [t.name for t in self.all_targets()]
        if len(set(names)) != len(names):
            raise InputError(f"targets: each target needs its own name, got {names}")

    def all_targets(self) -> tuple[DrawnTarget, ...]:
        """Every target drawn: the goal of ``goal_params`` (when given), then ``targets``."""
        goal = (DrawnTarget("goal", tuple(self.goal_params)),) if self.goal_params else ()
        return goal + self.targets

    def event_fields(self) -> dict[str, Any]:
        """The constant fields each roll-out event carries for this drawing (docs/PROTOCOL.md):
        ``goal_params`` as given, and with any target ``target_params`` (K, 3) int (-1: no z) and
        ``target_names`` (the K names joined by commas)."""
        fields: dict[str, Any] = {"goal_params": np.asarray(self.goal_params, dtype=np.int64)}
        targets = self.all_targets()
        if targets:
            fields["target_params"] = np.array([list(t.params) + [-1] * (3 - len(t.params)) for t in targets],
                                               dtype=np.int64)
            fields["target_names"] = ",".join(t.name for t in targets)
        return fields


@dataclass(frozen=True)
class Joint:
    """One actuated joint: its name (as in the robot's URDF) and position limits (rad)."""

    name: str
    lower: float
    upper: float


@dataclass(frozen=True)
class PlanarChainDrawing:
    """Draw a planar serial arm as a line strip: base, then the end of every link, from forward
    kinematics of the executed ``joint_angles`` (T, N) rad; the pushed object, when the roll-out
    has ``object_xy`` (T, 2) m, as a cylinder of ``object_radius`` and ``object_height`` (m)."""

    kind: ClassVar[str] = "planar_chain"
    #: roll-out states this drawing reads (the first is required, the others optional)
    states: ClassVar[tuple[str, ...]] = ("joint_angles", "object_xy")

    link_lengths: tuple[float, ...]
    object_radius: float = 0.03
    object_height: float = 0.06

    def event_fields(self) -> dict[str, Any]:
        """The constant fields each roll-out event carries for this drawing (docs/PROTOCOL.md)."""
        return {"link_lengths": np.asarray(self.link_lengths, dtype=np.float64),
                "object_radius": float(self.object_radius), "object_height": float(self.object_height)}


@dataclass(frozen=True)
class MeshChainDrawing:
    """Draw a robot with the collision shapes of its URDF (meshes and boxes), posed from the
    executed ``joint_angles`` (T, N) rad at every step (the drawer logs each shape once and its pose
    per step), the gripper from ``finger_opening`` (T,) m when present (every joint of
    ``opening_joints`` takes that value), and the handled box from ``object_xyz`` (T, 3) m and
    ``object_quat`` (T, 4) x, y, z, w; the scene's static parts travel as constant fields.

    robot : the robot kind; the recorder finds this drawing again through the registry.
    joint_names : the URDF joints of the trajectory's columns, in order.
    scene : constant named values of the scene (e.g. ``pick_xy`` (2,) m), sent with every event.
    opening_joints : URDF joints set to ``finger_opening``.
    urdf : returns the path of the URDF to draw (called by the recorder, not sent).
    """

    kind: ClassVar[str] = "mesh_chain"
    #: roll-out states this drawing reads (the first is required, the others optional)
    states: ClassVar[tuple[str, ...]] = ("joint_angles", "finger_opening", "object_xyz", "object_quat")

    robot: str
    joint_names: tuple[str, ...]
    scene: Mapping[str, Any] = field(default_factory=dict)
    opening_joints: tuple[str, ...] = ()
    urdf: Callable[[], Any] | None = field(default=None, compare=False, repr=False)

    def event_fields(self) -> dict[str, Any]:
        """The constant fields each roll-out event carries for this drawing (docs/PROTOCOL.md)."""
        return {"robot_kind": self.robot, **{k: np.asarray(v, dtype=np.float64) for k, v in self.scene.items()}}


@dataclass(frozen=True)
class PointSetDrawing:
    """Draw a set of points moving through a roll-out, e.g. the pouring rig's marbles: the state
    ``marble_xyz`` holds their positions (F, M, 3) m at the control steps ``frame_steps`` (F,). A
    holder (the cup: boxes in its own frame) turns by the state ``wrist_angle`` (T,) rad about the
    +y axis through ``pivot``; ``scene_boxes`` stand still; ``poured_g_t`` (T,) g is drawn as a
    scalar over the roll-out's steps.

    radius : of each point (m).
    holder_boxes, scene_boxes : tuples of (half extents (3,) m, centre (3,) m, pitch about +y rad).
    pivot : (3,) m, a point on the holder's axis.
    """

    kind: ClassVar[str] = "point_set"
    #: roll-out states this drawing reads (the first is required, the others optional)
    states: ClassVar[tuple[str, ...]] = ("marble_xyz", "frame_steps", "wrist_angle", "poured_g_t")

    radius: float
    holder_boxes: tuple = ()
    scene_boxes: tuple = ()
    pivot: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def event_fields(self) -> dict[str, Any]:
        """The constant fields each roll-out event carries for this drawing (docs/PROTOCOL.md): the
        radius, the pivot and each box set as ``<set>_half`` (B, 3), ``<set>_center`` (B, 3),
        ``<set>_pitch`` (B,)."""
        out: dict[str, Any] = {"point_radius": float(self.radius), "pivot": np.asarray(self.pivot, dtype=np.float64)}
        for name, boxes in (("holder", self.holder_boxes), ("scene", self.scene_boxes)):
            out[f"{name}_half"] = np.asarray([b[0] for b in boxes], dtype=np.float64).reshape(-1, 3)
            out[f"{name}_center"] = np.asarray([b[1] for b in boxes], dtype=np.float64).reshape(-1, 3)
            out[f"{name}_pitch"] = np.asarray([b[2] for b in boxes], dtype=np.float64).reshape(-1)
        return out


@dataclass(frozen=True)
class RobotBody:
    """What is loaded on first use of a robot kind (it may import its simulator's dependencies).

    joints : the actuated joints, in the order of a trajectory's columns (empty for a point robot).
    drawing : how a recording draws a roll-out (None: the trajectory alone is drawn).
    simulator : builds one simulator instance (a physics world); None for analytic robots.
    """

    joints: tuple[Joint, ...] = ()
    drawing: Any = None
    simulator: Callable[[], Any] | None = None


@dataclass(frozen=True)
class RobotSpec:
    """One robot kind.

    kind : the name used on the wire and on the command line (one key chunk, e.g. ``planar3``).
    summary : one line for ``--help`` texts and tables.
    tasks : task name -> the task parameters this robot fixes (a request may repeat a fixed value,
        never contradict it).
    body : returns the :class:`RobotBody`; called once, on first use.
    new_tasks : tasks this robot brings with it (name -> :class:`TaskFactory`), registered in the
        task registry with the robot; a plugin's robot names its own tasks here.
    """

    kind: str
    summary: str
    tasks: Mapping[str, Mapping[str, Any]]
    body: Callable[[], RobotBody] = field(default=RobotBody, compare=False, repr=False)
    new_tasks: Mapping[str, TaskFactory] = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.kind, str) or not _KIND.fullmatch(self.kind):
            raise InputError(f"kind: a robot kind is 1-40 letters, digits, '_' or '-' starting with a letter, "
                             f"got {self.kind!r}")
        if not isinstance(self.summary, str):
            raise InputError(f"summary: expected a string, got {type(self.summary).__name__}")
        if not isinstance(self.tasks, Mapping) or not self.tasks:
            raise InputError(f"tasks: robot {self.kind!r} must run at least one task (a map name -> fixed parameters)")
        if not callable(self.body):
            raise InputError(f"body: robot {self.kind!r}: expected a function returning a RobotBody")
        for name, params in self.tasks.items():
            if not isinstance(name, str) or not isinstance(params, Mapping):
                raise InputError(f"tasks: robot {self.kind!r}: expected task name -> map of fixed parameters, "
                                 f"got {name!r} -> {type(params).__name__}")
        if not isinstance(self.new_tasks, Mapping):
            raise InputError(f"new_tasks: robot {self.kind!r}: expected a map task name -> TaskFactory")
        for name, factory in self.new_tasks.items():
            if not isinstance(factory, TaskFactory):
                raise InputError(f"new_tasks.{name}: robot {self.kind!r}: expected a TaskFactory, "
                                 f"got {type(factory).__name__}")
        frozen = {t: MappingProxyType(dict(p)) for t, p in self.tasks.items()}
        object.__setattr__(self, "tasks", MappingProxyType(frozen))
        object.__setattr__(self, "new_tasks", MappingProxyType(dict(self.new_tasks)))

    @functools.cached_property
    def _body(self) -> RobotBody:
        body = self.body()
        if not isinstance(body, RobotBody):
            raise InputError(f"body: robot {self.kind!r}: its body function returned "
                             f"{type(body).__name__}, not a RobotBody")
        return body

    @property
    def joints(self) -> tuple[Joint, ...]:
        """The actuated joints (names, limits in rad), in trajectory column order."""
        return self._body.joints

    @property
    def drawing(self):
        """The drawing of this robot's roll-outs (see the module docstring), or None."""
        return self._body.drawing

    def make_simulator(self):
        """A new simulator instance; InputError for a robot without one (an analytic robot)."""
        if self._body.simulator is None:
            raise InputError(f"robot: {self.kind!r} has no simulator (it is evaluated analytically)")
        return self._body.simulator()

    def task_config(self, task: str, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The effective parameters of ``task`` on this robot: ``params`` merged with the fixed ones.

        Raises :class:`UnknownTaskError` when this robot does not run ``task``, :class:`InputError`
        when ``params`` contradicts a fixed parameter or is not a map.
        """
        if task not in self.tasks:
            raise UnknownTaskError(f"task: a {self.kind} robot runs {sorted(self.tasks)}, not {task!r}")
        if params is not None and not isinstance(params, Mapping):
            raise InputError(f"task_config: expected a map, got {type(params).__name__}")
        cfg = dict(params or {})
        for key, value in self.tasks[task].items():
            if key in cfg and cfg[key] != value:
                raise InputError(f"task_config.{key}: a {self.kind} robot has {key}={value!r}, got {cfg[key]!r}")
            cfg[key] = value
        try:  # task parameters are plain values: they travel in messages and job records
            json.dumps(cfg, sort_keys=True, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise InputError(f"task_config: must hold plain values ({exc})") from None
        return cfg

    def make_evaluator(self, task: str, params: Mapping[str, Any] | None = None) -> RolloutEvaluator:
        """Build the evaluator of ``task`` on this robot (parameters merged by :meth:`task_config`).

        Raises the errors of :meth:`task_config`, and :class:`InputError` for parameters the task
        refuses (missing, of the wrong type or value).
        """
        from ..tasks.registry import make_task

        cfg = self.task_config(task, params)
        try:
            if task in self.new_tasks:  # its own task (also before the robot is registered)
                return self.new_tasks[task].build(cfg)
            return make_task(task, cfg)
        except InputError:
            raise
        except (ValueError, TypeError, KeyError) as exc:  # the task's checks of its parameters
            raise InputError(str(exc)) from None
