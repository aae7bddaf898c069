"""The UR10 and the pouring rig are drawn from their registry drawings: real roll-outs (short ones)
become rollout events that carry the drawings' states; the writer logs the UR10's meshes once and
their poses per step, the marbles per frame, the cup turning and the poured mass; read back from the .rrd."""
from __future__ import annotations

import numpy as np
import pytest
import rerun as rr

from acnmp_core.robots.registry import robot
from acnmp_core.sim.ur10 import START_POSE_DEG
from services.recording.events import batch_rollout_events, decode_event
from services.recording.rrd_writer import RrdWriter
from services.transport import encode


def _chunks(path) -> dict[str, list]:
    reader = rr.chunk.RrdReader(path)
    out: dict[str, list] = {}
    for chunk in reader.stream(store=reader.recordings()[0]):
        out.setdefault(chunk.entity_path, []).append(chunk)
    return out


def _record(path, robot_kind: str, task: str, trajs, times, task_params):
    spec = robot(robot_kind)
    with spec.make_evaluator(task) as ev:
        batch = ev.evaluate(trajs, times, task_params)
    events = batch_rollout_events("job-1", 0, trajs, times, batch, task_params=task_params, drawing=spec.drawing)
    with RrdWriter(path) as w:
        for e in events:
            assert e["drawing"] == spec.drawing.kind
            w.log_event(decode_event(encode(e)))  # through the wire codec, as the recorder receives it
    return batch, _chunks(path)


def test_a_ur10_rollout_is_drawn_with_its_meshes_posed_per_step(tmp_path, verify_rrd):
    t = np.linspace(0.0, 1.0, 30)
    q = np.deg2rad(START_POSE_DEG) + np.linspace(0, 0.2, 30)[:, None] * np.array([1, 0, 0, 0, 0, 0])
    trajs = np.stack([q, q])
    path = tmp_path / "ur10.rrd"
    batch, chunks = _record(path, "ur10", "pick_place", trajs, t, np.array([0.04, 0.06]))
    verify_rrd(path)
    robot_entities = sorted(e for e in chunks if e.startswith("/arm/job-1/robot/"))
    assert len(robot_entities) == 11  # 7 UR10 meshes, the flange's box, the palm, two fingers
    base = chunks["/arm/job-1/robot/00_base_link"]
    assert sum(c.is_static for c in base) == 1  # the mesh is sent once for the two roll-outs
    temporal = [c for c in base if not c.is_static]
    assert sum(c.to_record_batch().num_rows for c in temporal) == 2 * 30  # a pose per step and roll-out
    assert {"/arm/job-1/object", "/arm/job-1/obstacle", "/arm/job-1/place"} <= set(chunks)


def test_a_pour_rollout_is_drawn_with_marbles_cup_and_poured_mass(tmp_path, verify_rrd):
    t = np.linspace(0.0, 1.0, 20)
    trajs = np.linspace(0.0, 0.3, 20)[None, :, None]
    path = tmp_path / "pour.rrd"
    batch, chunks = _record(path, "pour", "pour", trajs, t, np.array([650.0, 100.0]))
    verify_rrd(path)
    points = [c.to_record_batch() for c in chunks["/arm/job-1/points"] if not c.is_static]
    frames = batch.states["marble_xyz"].shape[1]
    assert sum(b.num_rows for b in points) == frames  # one row per frame, 23 marbles each
    rows = [p for b in points for p in b.column("Points3D:positions").to_pylist()]
    assert all(len(r) == 23 for r in rows)
    holder = chunks["/arm/job-1/holder"]
    assert any(c.is_static for c in holder) and sum(c.to_record_batch().num_rows for c in holder
                                                    if not c.is_static) == 20
    assert "/poured_g/job-1" in chunks and "/arm/job-1/scene" in chunks


def test_mesh_drawing_refuses_a_wrong_joint_count(tmp_path):
    from services.recording.drawings import draw_mesh_chain

    rec = rr.RecordingStream("test")
    with pytest.raises(ValueError, match="joint_angles"):
        draw_mesh_chain(rec, "j", 0, {"robot_kind": "ur10", "joint_angles": np.zeros((5, 4)), "t": 0.0}, (1, 2, 3))
