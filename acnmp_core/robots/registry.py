"""The robot registry: everything the system knows about a robot kind, in one entry.

A robot kind (``"point2d"``, ``"planar3"``, ...) names one simulated robot. Its :class:`RobotSpec`
says which registry tasks (:mod:`acnmp_core.tasks.registry`) it runs and which of their parameters
it fixes, and — loaded on first use, since simulators import PyBullet — its joints (names and
limits), how to build its simulator and how a recording draws it. Workers build their evaluators
from it, the learner validates jobs against it, the launcher and the command line take their
choices from it, and the recorder draws roll-outs from the drawing it names.

Adding a robot is one :func:`register_robot` call at the end of this module plus the robot's own
module (the simulator and the function that describes its body), e.g. for a UR10::

    register_robot(RobotSpec(
        "ur10", "UR10 with a two-finger gripper, pick and place over an obstacle (PyBullet)",
        tasks={"pick_place": {}}, body=lambda: import_module(".ur10", __package__).ur10_body()))

where ``ur10_body()`` returns a :class:`RobotBody` with the six joints read from the URDF, a
:class:`MeshChainDrawing`-like drawing (see "Drawings" below) and ``simulator=UR10Sim``.

Drawings
--------
A drawing is a small frozen dataclass with a ``kind`` (the recorder's dispatch key), ``states``
(the names of the :class:`~acnmp_core.rollout.RolloutBatch` states it needs from each roll-out)
and ``event_fields()`` (constant fields, e.g. link lengths, that travel with each roll-out event).
:class:`PlanarChainDrawing` draws a planar arm as a line strip from its joint angles; a mesh robot
would name its URDF and joints (its drawer logs the meshes once and a transform per link and
step), a set of points (the pouring rig's marbles) would name the state holding their positions.
The recorder (``services/recording/drawings.py``) holds one drawing function per kind.
"""
from __future__ import annotations

import functools
import json
from importlib import import_module
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, ClassVar, Mapping

import numpy as np

from ..errors import InputError, UnknownRobotError, UnknownTaskError
from ..rollout import RolloutEvaluator


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
    """

    kind: str
    summary: str
    tasks: Mapping[str, Mapping[str, Any]]
    body: Callable[[], RobotBody] = field(default=RobotBody, compare=False, repr=False)

    def __post_init__(self) -> None:
        frozen = {t: MappingProxyType(dict(p)) for t, p in self.tasks.items()}
        object.__setattr__(self, "tasks", MappingProxyType(frozen))

    @functools.cached_property
    def _body(self) -> RobotBody:
        return self.body()

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
            return make_task(task, cfg)
        except InputError:
            raise
        except ValueError as exc:  # the task registry's checks of the parameters
            raise InputError(str(exc)) from None


_ROBOTS: dict[str, RobotSpec] = {}


def register_robot(spec: RobotSpec) -> RobotSpec:
    """Add ``spec`` to the registry (its tasks must be registered tasks); returns it."""
    from ..tasks.registry import task_names

    unknown = sorted(set(spec.tasks) - set(task_names()))
    if unknown:
        raise UnknownTaskError(f"tasks: robot {spec.kind!r} names unregistered task(s) {unknown}")
    if spec.kind in _ROBOTS:
        raise InputError(f"kind: robot {spec.kind!r} is already registered")
    _ROBOTS[spec.kind] = spec
    return spec


def robot_kinds() -> tuple[str, ...]:
    """Every registered robot kind, in registration order (the first is the default)."""
    return tuple(_ROBOTS)


def robot(kind: str) -> RobotSpec:
    """The :class:`RobotSpec` of ``kind``; :class:`UnknownRobotError` naming the known kinds."""
    try:
        return _ROBOTS[kind]
    except (KeyError, TypeError):
        raise UnknownRobotError(f"robot: {kind!r} is not one of {list(_ROBOTS)}") from None


# --------------------------------------------------------------------------------------------
# the entries


def _planar_arm_body(n_joints: int) -> RobotBody:
    """The planar arms of :mod:`acnmp_core.robots.planar_arm` (imports PyBullet)."""
    from .planar_arm import PlanarArmSim, PushObject, default_geometry

    geometry, obj = default_geometry(n_joints), PushObject()
    joints = tuple(Joint(f"joint{i}", lo, hi) for i, (lo, hi) in enumerate(geometry.joint_limits))
    return RobotBody(joints, PlanarChainDrawing(geometry.link_lengths, obj.radius, obj.height),
                     functools.partial(PlanarArmSim, geometry, obj))


register_robot(RobotSpec("point2d", "a point moving in the plane, scored analytically (E1 via-point, E3 wall)",
                         tasks={"viapoint": {}, "wall": {}}))
register_robot(RobotSpec("planar3", "3-DoF planar arm pushing a cylinder (PyBullet; E2) or a cube through a gap (E4)",
                         tasks={"push": {"n_joints": 3}, "cube_gap": {"n_joints": 3}}, body=functools.partial(_planar_arm_body, 3)))
register_robot(RobotSpec("planar4", "4-DoF planar arm pushing a cylinder or a cube through a gap (PyBullet; E4)",
                         tasks={"push": {"n_joints": 4}, "cube_gap": {"n_joints": 4}}, body=functools.partial(_planar_arm_body, 4)))
register_robot(RobotSpec("ur10", "UR10 with a two-finger gripper, pick and place over an obstacle (PyBullet; E5)",
                         tasks={"pick_place": {}}, body=lambda: import_module(".ur10", __package__).ur10_body()))
register_robot(RobotSpec("pour", "a wrist pouring marbles from a cup into another (PyBullet; E6)",
                         tasks={"pour": {}}, body=lambda: import_module(".pour", __package__).pour_body()))
