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

from typing import Callable

import numpy as np
import rerun as rr

#: Height (m) at which a planar arm's links are drawn (the URDF's links sit just above the table).
ARM_Z = 0.03
#: ``rollout_step`` = rollout_index * STEP_STRIDE + step (more than any roll-out's step count).
STEP_STRIDE = 100_000

#: ``draw(rec, job, rollout_index, event, color)``; ``job`` is already an escaped entity path part.
Drawer = Callable[[rr.RecordingStream, str, int, dict, tuple], None]


def draw_planar_chain(rec: rr.RecordingStream, job: str, idx: int, msg: dict, color) -> None:
    """A planar arm: ``joint_angles`` (T, N) rad and ``link_lengths`` (N,) m, drawn in 3D (forward
    kinematics of acnmp_core/robots/kinematics.py, links at ``ARM_Z`` above the table); with
    ``object_xy`` (T, 2) m, ``object_radius`` and ``object_height`` (m) the pushed object as a
    cylinder; with ``task_params`` (x, y) the target as a point."""
    from acnmp_core.robots.kinematics import planar_fk

    q = np.asarray(msg["joint_angles"], dtype=np.float64)
    lengths = np.asarray(msg["link_lengths"], dtype=np.float64).reshape(-1)
    if q.ndim != 2 or q.shape[1] != lengths.shape[0] or not 1 <= q.shape[0] < STEP_STRIDE:
        raise ValueError(f"joint_angles: expected (T, {lengths.shape[0]}) with 1 <= T < {STEP_STRIDE}, "
                         f"got {q.shape}")
    steps, n = q.shape
    # Base, then the end of every link: the FK of each prefix of the chain.
    pts = np.zeros((steps, n + 1, 3))
    for i in range(1, n + 1):
        pts[:, i, :2] = planar_fk(q[:, :i], lengths[:i])[:, :2]
    pts[:, :, 2] = ARM_Z
    seq = np.arange(steps, dtype=np.int64)
    ones = np.ones(steps, dtype=np.int64)
    # Columns, not one log call per step: one chunk per roll-out and entity, cheap for T = 300.
    # Every component is a column (one value per step) so each frame is complete on every timeline.
    indexes = [rr.TimeColumn("step", sequence=seq),
               rr.TimeColumn("rollout", sequence=np.full(steps, idx, dtype=np.int64)),
               rr.TimeColumn("rollout_step", sequence=idx * STEP_STRIDE + seq),
               rr.TimeColumn("wall_time", timestamp=np.full(steps, float(msg["t"])))]
    rec.send_columns(
        f"arm/{job}/links", indexes=indexes,
        columns=rr.LineStrips3D.columns(strips=list(pts.astype(np.float32)), colors=[color] * steps,
                                        radii=np.full(steps, 0.006, np.float32)).partition(ones))
    # The per-roll-out markers appear from the roll-out's first step on every timeline.
    rec.set_time("step", sequence=0)
    rec.set_time("rollout_step", sequence=idx * STEP_STRIDE)
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
                                           colors=[(200, 40, 40)] * steps).partition(ones))
        rec.log(f"arm/{job}/object_path", rr.LineStrips3D(
            [np.concatenate([obj, np.zeros((steps, 1))], axis=1)], colors=[color], labels=[f"#{idx}"]))
    tp = msg.get("task_params")
    if tp is not None and np.asarray(tp).shape == (2,):
        rec.log(f"arm/{job}/target", rr.Points3D([[*np.asarray(tp, dtype=np.float64), 0.0]], radii=[0.01],
                                                      colors=[(40, 120, 220)], labels=["target"]))


#: Drawing kind -> its function.
DRAWERS: dict[str, Drawer] = {"planar_chain": draw_planar_chain}


def drawer_for(msg: dict) -> Drawer | None:
    """The function drawing the robot of rollout event ``msg``, or None (no drawing, or one this
    recorder does not know). Events of recorders before drawings had a kind carry a planar arm's
    ``joint_angles`` and ``link_lengths`` without ``drawing``."""
    kind = msg.get("drawing")
    if kind is None and msg.get("joint_angles") is not None and msg.get("link_lengths") is not None:
        kind = "planar_chain"
    return DRAWERS.get(kind) if kind is not None else None
