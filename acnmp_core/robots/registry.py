"""The robot registry: every robot kind the system knows, built in or brought by a plugin.

A robot kind (``"point2d"``, ``"planar3"``, ...) names one robot, described by a
:class:`~acnmp_core.robots.spec.RobotSpec` (the types live in :mod:`acnmp_core.robots.spec`, so a
plugin imports them without this registry). Workers build their evaluators from it, the learner
validates jobs against it, the launcher and the command line take their choices from it, and the
recorder draws roll-outs from the drawing it names.

Kinds come from three places, looked up in this order the first time any kind is asked for:

1. built in: the :func:`register_robot` calls at the end of this module;
2. installed plugins: entry points of the group ``acnmp.robots`` (:mod:`acnmp_core.robots.plugins`);
3. references ``package.module:attr`` in the environment variable ``ACNMP_ROBOT_PLUGINS``
   (comma-separated), or given where a kind is expected (``robot("my_pkg.robots:ARM")``).

A plugin that cannot be loaded (import error, not a RobotSpec, a kind or task name that clashes)
is left out with one line saying why (:func:`plugin_problems`); every other kind keeps working.
"""
from __future__ import annotations

import functools
import os
from importlib import import_module

from ..errors import InputError, UnknownRobotError, UnknownTaskError
from . import plugins
from .spec import (DrawnTarget, EndEffectorPathDrawing, Joint, MeshChainDrawing, PlanarChainDrawing, PointSetDrawing,
                   RobotBody, RobotSpec, TaskFactory)

_ROBOTS: dict[str, RobotSpec] = {}
#: kind -> where it came from ("built in", "entry point ...", "reference ...")
_SOURCES: dict[str, str] = {}
_PROBLEMS: list[plugins.PluginProblem] = []
_PLUGINS_LOADED = False
#: the environment variable naming plugin references to load in every process (comma-separated)
PLUGINS_ENV = "ACNMP_ROBOT_PLUGINS"


def register_robot(spec: RobotSpec, source: str = "built in") -> RobotSpec:
    """Add ``spec`` to the registry, with the tasks it brings (``spec.new_tasks``); returns it.

    Every task it runs must be registered or brought by it. Raises :class:`InputError` for a kind
    already registered (unless it is the same spec again, e.g. a plugin both installed and named
    by reference) or a brought task whose name is taken, :class:`UnknownTaskError` for a task
    nobody registered; nothing is registered then.
    """
    from ..tasks.registry import add_task, task_names

    if not isinstance(spec, RobotSpec):
        raise InputError(f"expected a RobotSpec, got {type(spec).__name__}")
    if spec.kind in _ROBOTS:
        if _ROBOTS[spec.kind] == spec and dict(_ROBOTS[spec.kind].new_tasks) == dict(spec.new_tasks):
            return _ROBOTS[spec.kind]
        raise InputError(f"kind: robot {spec.kind!r} is already registered ({_SOURCES[spec.kind]})")
    taken = sorted(set(spec.new_tasks) & set(task_names()))
    if taken:
        raise InputError(f"new_tasks: robot {spec.kind!r} brings task(s) {taken} whose name is already taken")
    unknown = sorted(set(spec.tasks) - set(task_names()) - set(spec.new_tasks))
    if unknown:
        raise UnknownTaskError(f"tasks: robot {spec.kind!r} names unregistered task(s) {unknown}")
    for name, factory in spec.new_tasks.items():
        add_task(name, factory.build, factory.credit)
    _ROBOTS[spec.kind] = spec
    _SOURCES[spec.kind] = source
    return spec


def _load_plugins() -> None:
    """Load the installed plugins and those of ``ACNMP_ROBOT_PLUGINS`` once per process."""
    global _PLUGINS_LOADED
    if _PLUGINS_LOADED:
        return
    _PLUGINS_LOADED = True
    refs = [r.strip() for r in os.environ.get(PLUGINS_ENV, "").split(",") if r.strip()]
    for found in (*plugins.installed(), *(plugins.Found(f"{ref} ({PLUGINS_ENV})", ref) for ref in refs)):
        try:
            for spec in found.specs():
                register_robot(spec, found.source)
        except plugins.PluginError as exc:
            _PROBLEMS.append(plugins.PluginProblem(found.source, str(exc)))
        except InputError as exc:  # a clash, or a malformed spec found while registering
            _PROBLEMS.append(plugins.PluginProblem(found.source, str(exc)))


def plugin_problems() -> tuple[plugins.PluginProblem, ...]:
    """The plugins that could not be loaded, each with its one-line reason."""
    _load_plugins()
    return tuple(_PROBLEMS)


def robot_kinds() -> tuple[str, ...]:
    """Every registered robot kind, built-in ones first in registration order (the first is the
    default), then the plugins' ones."""
    _load_plugins()
    return tuple(_ROBOTS)


def robot_source(kind: str) -> str:
    """Where the registered ``kind`` comes from ("built in", "entry point NAME (DIST)", a reference)."""
    robot(kind)
    return _SOURCES[kind]


def plugins_for_children() -> str:
    """The value of ``ACNMP_ROBOT_PLUGINS`` for a child process: this process's own, plus every
    plugin it loaded by reference, so that the child knows the same robot kinds."""
    refs = [r.strip() for r in os.environ.get(PLUGINS_ENV, "").split(",") if r.strip()]
    refs += [ref for ref in _REFERENCES if ref not in refs]
    return ",".join(refs)


#: the references loaded in this process (``robot("pkg.mod:attr")``), in order
_REFERENCES: list[str] = []


@functools.lru_cache(maxsize=None)
def _reference(ref: str) -> RobotSpec:
    found = plugins.Found(ref, ref)
    specs = found.specs()
    if len(specs) != 1:
        raise plugins.PluginError(f"expected one RobotSpec, found {len(specs)}")
    spec = register_robot(specs[0], found.source)
    _REFERENCES.append(ref)
    return spec


def robot(kind: str) -> RobotSpec:
    """The :class:`RobotSpec` of ``kind``, a registered kind or a reference ``package.module:attr``
    to a plugin's RobotSpec (loaded and registered on first use, under the spec's own kind).

    Raises :class:`UnknownRobotError` (an :class:`InputError`) naming the known kinds, and any
    plugin that could not be loaded; for a reference, one line naming it and why it failed.
    """
    _load_plugins()
    if isinstance(kind, str) and ":" in kind:
        try:
            return _reference(kind)
        except (plugins.PluginError, InputError) as exc:
            raise UnknownRobotError(f"robot: plugin {kind!r}: {exc}") from None
    try:
        return _ROBOTS[kind]
    except (KeyError, TypeError):
        broken = "".join(f"; {p}" for p in _PROBLEMS)
        raise UnknownRobotError(f"robot: {kind!r} is not one of {list(_ROBOTS)}{broken}") from None


# --------------------------------------------------------------------------------------------
# the entries


def _planar_arm_body(n_joints: int) -> RobotBody:
    """The planar arms of :mod:`acnmp_core.sim.planar_arm` (imports PyBullet)."""
    from ..sim.planar_arm import PlanarArmSim, PushObject, default_geometry

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
# through the Gymnasium adapter, as a plugin would (gymnasium is imported on first use only)
register_robot(import_module(".pusher", __package__).PUSHER)
# Meta-World's Sawyer tasks, the same way (metaworld is imported on first use only)
for _spec in import_module(".metaworld", __package__).KINDS:
    register_robot(_spec)
