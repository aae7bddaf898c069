"""How a recording draws a robot's roll-out: one function per drawing kind of the robot registry.

A rollout event names its robot's drawing (``drawing``, a kind of acnmp_core/robots/registry.py)
and carries that drawing's fields and the states it needs. :func:`drawer_for` picks the function;
each logs under ``/arm/<job>`` one frame per control step on the timelines ``step``, ``rollout``,
``rollout_step`` and ``wall_time`` (services/recording/rrd_writer.py explains them). A drawing kind
this recorder does not know is not drawn (the trajectory, reward and return still are), so an older
recorder keeps recording a newer robot. Adding a robot with a new kind of drawing (a mesh robot, a
set of points) is one function here plus its entry in :data:`DRAWERS`.
"""
from __future__ import annotations

import functools
from typing import Callable

import numpy as np
import rerun as rr

#: Height (m) at which a planar arm's links are drawn (the URDF's links sit just above the table).
ARM_Z = 0.03
#: ``rollout_step`` = rollout_index * STEP_STRIDE + step (more than any roll-out's step count).
STEP_STRIDE = 100_000

#: Colour of a reference arm drawn beside the roll-out's (``reference_joint_angles``).
REFERENCE_COLOR = (150, 150, 150)
#: Colours of an ``ee_path`` drawing's targets, in the order the event names them.
TARGET_COLORS = ((40, 120, 220), (230, 160, 30), (150, 70, 200), (40, 170, 170))

#: ``draw(rec, job, rollout_index, event, color)``; ``job`` is already an escaped entity path part.
Drawer = Callable[[rr.RecordingStream, str, int, dict, tuple], None]


def draw_planar_chain(rec: rr.RecordingStream, job: str, idx: int, msg: dict, color) -> None:
    """A planar arm: ``joint_angles`` (T, N) rad and ``link_lengths`` (N,) m, drawn in 3D (forward
    kinematics of acnmp_core/sim/kinematics.py, links at ``ARM_Z`` above the table); with
    ``object_xy`` (T, 2) m, ``object_radius`` and ``object_height`` (m) the pushed object as a
    cylinder; with ``task_params`` (x, y) the target as a point; with ``reference_joint_angles``
    (T, N') rad and ``reference_link_lengths`` (N',) m another arm's pose at the same steps, in grey
    under ``/arm/<job>/reference`` (E4: robot A's demonstration beside robot B's roll-out)."""

    q = np.asarray(msg["joint_angles"], dtype=np.float64)
    lengths = np.asarray(msg["link_lengths"], dtype=np.float64).reshape(-1)
    if q.ndim != 2 or q.shape[1] != lengths.shape[0] or not 1 <= q.shape[0] < STEP_STRIDE:
        raise ValueError(f"joint_angles: expected (T, {lengths.shape[0]}) with 1 <= T < {STEP_STRIDE}, "
                         f"got {q.shape}")
    steps = q.shape[0]
    # Columns, not one log call per step: one chunk per roll-out and entity, cheap for T = 300.
    # Every component is a column (one value per step) so each frame is complete on every timeline.
    indexes = _indexes(idx, np.arange(steps, dtype=np.int64), msg)
    _send_chain(rec, f"arm/{job}/links", q, lengths, indexes, color, 0.006)
    if msg.get("reference_joint_angles") is not None:
        # another robot's pose at the same steps (E4: robot A's demonstration beside robot B's roll-out)
        ref = np.asarray(msg["reference_joint_angles"], dtype=np.float64)
        ref_lengths = np.asarray(msg["reference_link_lengths"], dtype=np.float64).reshape(-1)
        if ref.ndim != 2 or ref.shape != (steps, ref_lengths.shape[0]):
            raise ValueError(f"reference_joint_angles: expected ({steps}, {ref_lengths.shape[0]}), got {ref.shape}")
        _send_chain(rec, f"arm/{job}/reference", ref, ref_lengths, indexes, REFERENCE_COLOR, 0.004)
    _at_first_step(rec, idx)
    obj = msg.get("object_xy")
    if obj is not None:
        obj = np.asarray(obj, dtype=np.float64)
        if obj.shape != (steps, 2):
            raise ValueError(f"object_xy: expected ({steps}, 2), got {obj.shape}")
        radius = float(msg.get("object_radius", 0.03))
        height = float(msg.get("object_height", 0.06))
        centers = np.concatenate([obj, np.full((steps, 1), height / 2)], axis=1).astype(np.float32)
        rec.send_columns(
            f"arm/{job}/object", indexes=indexes,
            columns=rr.Cylinders3D.columns(centers=centers, lengths=np.full(steps, height, np.float32),
                                           radii=np.full(steps, radius, np.float32),
                                           colors=[(200, 40, 40)] * steps).partition(np.ones(steps, np.int64)))
        rec.log(f"arm/{job}/object_path", rr.LineStrips3D(
            [np.concatenate([obj, np.zeros((steps, 1))], axis=1)], colors=[color], labels=[f"#{idx}"]))
    tp = msg.get("task_params")
    if tp is not None and np.asarray(tp).shape == (2,):
        rec.log(f"arm/{job}/target", rr.Points3D([[*np.asarray(tp, dtype=np.float64), 0.0]], radii=[0.01],
                                                      colors=[(40, 120, 220)], labels=["target"]))


def _send_chain(rec: rr.RecordingStream, entity: str, q: np.ndarray, lengths: np.ndarray, indexes: list,
                color, radius: float) -> None:
    """A planar chain's links, base to tip, one strip per step: q (T, N) rad, lengths (N,) m."""
    from acnmp_core.sim.kinematics import planar_fk

    steps, n = q.shape
    # Base, then the end of every link: the FK of each prefix of the chain.
    pts = np.zeros((steps, n + 1, 3))
    for i in range(1, n + 1):
        pts[:, i, :2] = planar_fk(q[:, :i], lengths[:i])[:, :2]
    pts[:, :, 2] = ARM_Z
    rec.send_columns(
        entity, indexes=indexes,
        columns=rr.LineStrips3D.columns(strips=list(pts.astype(np.float32)), colors=[color] * steps,
                                        radii=np.full(steps, radius, np.float32)).partition(np.ones(steps, np.int64)))


def _indexes(idx: int, steps: np.ndarray, msg: dict) -> list:
    """The time columns of roll-out ``idx`` at control steps ``steps`` (S,) int: ``step``,
    ``rollout``, ``rollout_step`` and ``wall_time`` (the event's time ``t``)."""
    n = len(steps)
    return [rr.TimeColumn("step", sequence=steps),
            rr.TimeColumn("rollout", sequence=np.full(n, idx, dtype=np.int64)),
            rr.TimeColumn("rollout_step", sequence=idx * STEP_STRIDE + steps),
            rr.TimeColumn("wall_time", timestamp=np.full(n, float(msg["t"])))]


def _at_first_step(rec: rr.RecordingStream, idx: int) -> None:
    """Set the clock to roll-out ``idx``'s first step: what is logged next appears from there on."""
    rec.set_time("step", sequence=0)
    rec.set_time("rollout_step", sequence=idx * STEP_STRIDE)


def _array(msg: dict, name: str, shape: tuple) -> np.ndarray:
    """Field ``name`` as float64 with ``shape`` (-1: any length); ValueError naming it otherwise."""
    a = np.asarray(msg[name], dtype=np.float64)
    if a.ndim != len(shape) or any(w not in (-1, n) for w, n in zip(shape, a.shape)):
        raise ValueError(f"{name}: expected shape {shape} (-1: any), got {a.shape}")
    return a


def _pitch_quats(pitch: np.ndarray) -> np.ndarray:
    """(N, 4) x, y, z, w quaternions of rotations by ``pitch`` (N,) rad about +y."""
    half = 0.5 * np.asarray(pitch, dtype=np.float64)
    return np.stack([np.zeros_like(half), np.sin(half), np.zeros_like(half), np.cos(half)], axis=-1)


@functools.lru_cache(maxsize=4)
def _link_poser(robot_kind: str):
    """The :class:`~acnmp_core.sim.physics.LinkPoser` of a mesh robot kind (built once)."""
    from acnmp_core.sim.physics import LinkPoser
    from acnmp_core.robots.registry import robot

    drawing = robot(robot_kind).drawing
    if drawing is None or getattr(drawing, "urdf", None) is None:
        raise ValueError(f"robot_kind: {robot_kind!r} has no URDF to draw")
    return LinkPoser(drawing.urdf()), drawing


#: (recording id, entity) of the static shapes already logged: each shape's mesh is sent once.
_LOGGED: set[tuple[str, str]] = set()


def _log_once(rec: rr.RecordingStream, entity: str, archetype_factory) -> None:
    """Log ``archetype_factory()`` as static data at ``entity`` unless this recording has it."""
    key = (rec.get_recording_id() or "", entity)
    if key not in _LOGGED:
        rec.log(entity, archetype_factory(), static=True)
        _LOGGED.add(key)


def draw_mesh_chain(rec: rr.RecordingStream, job: str, idx: int, msg: dict, color) -> None:
    """A mesh robot (``robot_kind``, e.g. the UR10): every collision shape of its URDF (STL meshes
    and boxes) logged once under ``/arm/<job>/robot`` and posed at every step from ``joint_angles``
    (T, N) rad (and ``finger_opening`` (T,) m); the handled box from ``object_xyz`` (T, 3),
    ``object_quat`` (T, 4) and ``object_size`` (2,) with its height ``task_params[0]`` (m); the
    obstacle (``obstacle_xy``, ``obstacle_size``, height ``task_params[1]``) and the place position
    (``place_xy``) from the roll-out's first step."""
    poser, drawing = _link_poser(str(msg["robot_kind"]))
    q = _array(msg, "joint_angles", (-1, len(drawing.joint_names)))
    steps = q.shape[0]
    if not 1 <= steps < STEP_STRIDE:
        raise ValueError(f"joint_angles: expected 1 <= T < {STEP_STRIDE} steps, got {steps}")
    values = {n: q[:, i] for i, n in enumerate(drawing.joint_names)}
    if msg.get("finger_opening") is not None:
        opening = _array(msg, "finger_opening", (steps,))
        values.update({n: opening for n in drawing.opening_joints})
    pos, quat = poser.poses(values)
    indexes = _indexes(idx, np.arange(steps, dtype=np.int64), msg)
    ones = np.ones(steps, dtype=np.int64)
    for i, shape in enumerate(poser.shapes):
        entity = f"arm/{job}/robot/{i:02d}_{rr.escape_entity_path_part(shape.link)}"
        if shape.kind == "mesh":
            _log_once(rec, entity, lambda s=shape: rr.Asset3D(path=s.mesh, albedo_factor=(170, 175, 185, 255)))
        else:
            _log_once(rec, entity, lambda s=shape: rr.Boxes3D(half_sizes=[s.half_extents], colors=[(60, 60, 60)],
                                                              fill_mode="solid"))
        rec.send_columns(entity, indexes=indexes,
                         columns=rr.Transform3D.columns(translation=pos[:, i], quaternion=quat[:, i]).partition(ones))
    tp = msg.get("task_params")
    heights = np.asarray(tp, dtype=np.float64).reshape(-1) if tp is not None else np.zeros(2)
    if msg.get("object_xyz") is not None and msg.get("object_quat") is not None and msg.get("object_size") is not None:
        size = _array(msg, "object_size", (2,))
        half = np.tile([size[0] / 2, size[1] / 2, heights[0] / 2], (steps, 1))
        rec.send_columns(f"arm/{job}/object", indexes=indexes, columns=rr.Boxes3D.columns(
            half_sizes=half, centers=_array(msg, "object_xyz", (steps, 3)),
            quaternions=_array(msg, "object_quat", (steps, 4)), colors=[(200, 40, 40)] * steps).partition(ones))
    _at_first_step(rec, idx)
    if msg.get("obstacle_xy") is not None and msg.get("obstacle_size") is not None and len(heights) > 1:
        (ox, oy), (sx, sy) = _array(msg, "obstacle_xy", (2,)), _array(msg, "obstacle_size", (2,))
        rec.log(f"arm/{job}/obstacle", rr.Boxes3D(half_sizes=[(sx / 2, sy / 2, heights[1] / 2)],
                                                  centers=[(ox, oy, heights[1] / 2)], colors=[(90, 90, 200)]))
    if msg.get("place_xy") is not None:
        rec.log(f"arm/{job}/place", rr.Points3D([[*_array(msg, "place_xy", (2,)), 0.0]], radii=[0.01],
                                                colors=[(40, 160, 40)], labels=["place"]))


def draw_point_set(rec: rr.RecordingStream, job: str, idx: int, msg: dict, color) -> None:
    """A set of points (the pouring rig's marbles): ``marble_xyz`` (F, M, 3) m at the control
    steps ``frame_steps`` (F,) as points of ``point_radius``; the holder's boxes (``holder_*``, in
    its own frame) turned by ``wrist_angle`` (T,) rad about +y through ``pivot`` at every step; the
    scene's boxes (``scene_*``) from the roll-out's first step; ``poured_g_t`` (T,) g as a scalar
    at ``/poured_g/<job>``."""
    xyz = _array(msg, "marble_xyz", (-1, -1, 3))
    frames, n_points = xyz.shape[:2]
    fsteps = np.asarray(msg.get("frame_steps", np.arange(frames)), dtype=np.int64).reshape(-1)
    if fsteps.shape != (frames,) or np.any(fsteps < 0) or np.any(fsteps >= STEP_STRIDE):
        raise ValueError(f"frame_steps: expected {frames} steps in [0, {STEP_STRIDE}), got {fsteps.tolist()}")
    radius = float(msg.get("point_radius", 0.01))
    rec.send_columns(f"arm/{job}/points", indexes=_indexes(idx, fsteps, msg), columns=rr.Points3D.columns(
        positions=xyz.reshape(-1, 3), radii=np.full(frames * n_points, radius, np.float32),
        colors=[color] * (frames * n_points)).partition(np.full(frames, n_points, dtype=np.int64)))
    pivot = _array(msg, "pivot", (3,)) if msg.get("pivot") is not None else np.zeros(3)
    if msg.get("wrist_angle") is not None:
        angle = _array(msg, "wrist_angle", (-1,))
        steps = len(angle)
        turn = _pitch_quats(angle)
        _log_once(rec, f"arm/{job}/holder", lambda: rr.Boxes3D(
            half_sizes=_array(msg, "holder_half", (-1, 3)), centers=_array(msg, "holder_center", (-1, 3)),
            quaternions=_pitch_quats(_array(msg, "holder_pitch", (-1,))), colors=[(120, 120, 140)], fill_mode="solid"))
        rec.send_columns(f"arm/{job}/holder", indexes=_indexes(idx, np.arange(steps, dtype=np.int64), msg),
                         columns=rr.Transform3D.columns(translation=np.tile(pivot, (steps, 1)),
                                                        quaternion=turn).partition(np.ones(steps, dtype=np.int64)))
    if msg.get("poured_g_t") is not None:
        poured = _array(msg, "poured_g_t", (-1,))
        rec.send_columns(f"poured_g/{job}", indexes=_indexes(idx, np.arange(len(poured), dtype=np.int64), msg),
                         columns=rr.Scalars.columns(scalars=poured))
    if msg.get("scene_half") is not None:
        _log_once(rec, f"arm/{job}/scene", lambda: rr.Boxes3D(
            half_sizes=_array(msg, "scene_half", (-1, 3)), centers=_array(msg, "scene_center", (-1, 3)),
            quaternions=_pitch_quats(_array(msg, "scene_pitch", (-1,))), colors=[(90, 90, 200)]))


def draw_ee_path(rec: rr.RecordingStream, job: str, idx: int, msg: dict, color) -> None:
    """Any robot by its end effector: ``ee_xyz`` (T, 3) m as a moving point and the roll-out's path;
    with ``object_xyz`` (T, 3) m the handled object likewise; the task's points as labelled
    targets under ``/arm/<job>/targets/<name>``: ``target_params`` (K, 3) indices into
    ``task_params`` (-1: no z) named by ``target_names`` (K names, comma-separated), or, in
    events of senders before several targets, ``goal_params`` as the one named "goal" (e.g. a
    Gymnasium arm's via-point and goal, acnmp_core/robots/gym_robot.py)."""
    ee = _array(msg, "ee_xyz", (-1, 3))
    steps = ee.shape[0]
    if not 1 <= steps < STEP_STRIDE:
        raise ValueError(f"ee_xyz: expected 1 <= T < {STEP_STRIDE} steps, got {steps}")
    indexes = _indexes(idx, np.arange(steps, dtype=np.int64), msg)
    parts = [("effector", ee, color, 0.012)]
    if msg.get("object_xyz") is not None:
        parts.append(("object", _array(msg, "object_xyz", (steps, 3)), (200, 40, 40), 0.025))
    for name, path, colour, radius in parts:
        rec.send_columns(f"arm/{job}/{name}", indexes=indexes, columns=rr.Points3D.columns(
            positions=path.astype(np.float32), colors=[colour] * steps,
            radii=np.full(steps, radius, np.float32)).partition(np.ones(steps, np.int64)))
    _at_first_step(rec, idx)
    for name, path, colour, _ in parts:
        rec.log(f"arm/{job}/{name}_path", rr.LineStrips3D([path], colors=[colour], labels=[f"#{idx}"]))
    tp = msg.get("task_params")
    if tp is None:
        return
    tp = np.asarray(tp, dtype=np.float64).reshape(-1)
    for k, (name, index) in enumerate(_targets(msg)):
        index = index[index >= 0]
        if index.size not in (2, 3) or int(index.max()) >= tp.size:
            continue  # a target the roll-out's task parameters do not hold
        xyz = np.zeros(3)
        xyz[:index.size] = tp[index]
        if index.size == 2:  # a point on the ground: at the object's (or effector's) first height
            xyz[2] = (parts[-1][1])[0, 2]
        rec.log(f"arm/{job}/targets/{rr.escape_entity_path_part(name)}",
                rr.Points3D([xyz], radii=[0.02], colors=[TARGET_COLORS[k % len(TARGET_COLORS)]], labels=[name]))


def _targets(msg: dict) -> list[tuple[str, np.ndarray]]:
    """(name, indices (3,) with -1 for no z) of each target an ``ee_path`` event names."""
    if msg.get("target_params") is not None:
        index = np.asarray(msg["target_params"], dtype=np.int64).reshape(-1, 3)
        names = str(msg.get("target_names", "")).split(",")
        if len(names) != len(index):
            raise ValueError(f"target_names: expected {len(index)} comma-separated names, got {msg.get('target_names')!r}")
        return list(zip(names, index))
    goal = np.asarray(msg.get("goal_params", ()), dtype=np.int64).reshape(-1)
    return [("goal", np.concatenate([goal, [-1] * (3 - goal.size)]))] if goal.size in (2, 3) else []


#: Drawing kind -> its function.
DRAWERS: dict[str, Drawer] = {"planar_chain": draw_planar_chain, "mesh_chain": draw_mesh_chain,
                              "point_set": draw_point_set, "ee_path": draw_ee_path}


def drawer_for(msg: dict) -> Drawer | None:
    """The function drawing the robot of rollout event ``msg``, or None (no drawing, or one this
    recorder does not know). Events of recorders before drawings had a kind carry a planar arm's
    ``joint_angles`` and ``link_lengths`` without ``drawing``."""
    kind = msg.get("drawing")
    if kind is None and msg.get("joint_angles") is not None and msg.get("link_lengths") is not None:
        kind = "planar_chain"
    return DRAWERS.get(kind) if kind is not None else None
