"""A rollout event carrying a planar arm's states is drawn in 3D: the arm (forward kinematics) and the
object, one frame per control step on the roll-out's own ``step`` timeline; read back from the .rrd.
Events name their robot's drawing kind; events without one (older senders) are drawn as before,
and a kind this recorder does not know is recorded without a drawing."""
from __future__ import annotations

import numpy as np
import pytest
import rerun as rr

from acnmp_core.sim.kinematics import planar_fk
from acnmp_core.robots.registry import robot
from services.recording.drawings import ARM_Z, STEP_STRIDE
from services.recording.events import decode_event, rollout_event
from services.recording.replay import summarize
from services.recording.rrd_writer import RrdWriter
from services.transport import encode

T = 40
LENGTHS = np.array([0.30, 0.30, 0.12])


def _states(seed: int):
    rng = np.random.default_rng(seed)
    q = np.cumsum(rng.normal(0, 0.02, size=(T, 3)), axis=0) + np.array([-0.8, 1.2, -1.0])
    obj = np.stack([np.linspace(0.35, 0.42, T), np.linspace(0.0, 0.05, T)], axis=1)
    return q, obj


def _event(idx: int, q, obj, **extra) -> dict:
    reward = np.zeros(T)
    reward[-1] = -0.05
    msg = rollout_event("push-extrapolation", idx, q, np.linspace(0, 1, T), reward, success=idx == 1,
                        space="joint", task_params=[0.42, 0.05], worker="w0")
    msg.update(joint_angles=q, link_lengths=LENGTHS, object_xy=obj, object_radius=0.03, object_height=0.06, **extra)
    # through the wire codec, as the recorder receives it
    return decode_event(encode(msg))


def _cols(batch) -> dict[str, list]:
    """Columns as Python lists (timestamp columns skipped: pyarrow cannot convert ns to datetime)."""
    return {n: batch.column(n).to_pylist() for n in batch.schema.names if n not in ("wall_time", "log_time")}


def _read(path) -> dict[str, list]:
    reader = rr.chunk.RrdReader(path)
    out: dict[str, list] = {}
    for chunk in reader.stream(store=reader.recordings()[0]):
        if chunk.entity_path.startswith("/arm") and not chunk.is_static:
            out.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())
    return out


@pytest.mark.parametrize("drawing", [{}, {"drawing": "planar_chain"}], ids=["legacy", "named"])
def test_arm_and_object_are_logged_per_step(tmp_path, drawing):
    path = tmp_path / "arm.rrd"
    states = [_states(s) for s in range(2)]
    with RrdWriter(path) as w:
        for i, (q, obj) in enumerate(states):
            w.log_event(_event(i, q, obj, **drawing))
    chunks = _read(path)
    job = "/arm/push-extrapolation"
    assert {f"{job}/links", f"{job}/object", f"{job}/object_path", f"{job}/target"} <= set(chunks)

    links = chunks[f"{job}/links"]
    assert sum(b.num_rows for b in links) == 2 * T
    for i, batch in enumerate(links):
        q, _ = states[i]
        cols = _cols(batch)
        assert cols["step"] == list(range(T))
        assert set(cols["rollout"]) == {i}
        assert cols["rollout_step"] == [i * STEP_STRIDE + k for k in range(T)]
        strips = cols["LineStrips3D:strips"]
        assert len(strips) == T
        for k in (0, T // 2, T - 1):
            pts = np.asarray(strips[k][0])  # one strip per step: base, joints, tip
            assert pts.shape == (4, 3)
            np.testing.assert_allclose(pts[0], [0.0, 0.0, ARM_Z], atol=1e-6)
            np.testing.assert_allclose(pts[-1, :2], planar_fk(q[k], LENGTHS)[:2], atol=1e-5)
            np.testing.assert_allclose(np.linalg.norm(np.diff(pts[:, :2], axis=0), axis=1), LENGTHS, atol=1e-5)

    objects = chunks[f"{job}/object"]
    assert sum(b.num_rows for b in objects) == 2 * T
    cols = _cols(objects[1])
    centers = np.asarray([c[0] for c in cols["Cylinders3D:centers"]])
    np.testing.assert_allclose(centers[:, :2], states[1][1], atol=1e-6)
    np.testing.assert_allclose(centers[:, 2], 0.03, atol=1e-6)
    assert cols["Cylinders3D:radii"][0] == [pytest.approx(0.03)]


def test_events_without_arm_states_log_no_arm(tmp_path):
    path = tmp_path / "plain.rrd"
    q, _ = _states(0)
    with RrdWriter(path) as w:
        w.log_event(rollout_event("plain", 0, q, np.linspace(0, 1, T), np.zeros(T), space="joint"))
    assert _read(path) == {}


def test_an_unknown_drawing_kind_is_recorded_without_a_drawing(tmp_path):
    path = tmp_path / "future.rrd"
    q, obj = _states(0)
    with RrdWriter(path) as w:
        w.log_event(_event(0, q, obj, drawing="hologram"))  # a kind of some future robot
    assert _read(path) == {}
    assert summarize(path)["jobs"]["push-extrapolation"]["rollouts"] == 1


def test_the_registry_drawing_of_a_planar_arm_is_what_the_writer_draws():
    drawing = robot("planar3").drawing
    assert drawing.kind == "planar_chain" and set(drawing.states) == {"joint_angles", "object_xy"}
    np.testing.assert_allclose(drawing.event_fields()["link_lengths"], LENGTHS)


def test_mismatched_joint_count_is_rejected(tmp_path):
    q, obj = _states(0)
    msg = _event(0, q, obj)
    msg["link_lengths"] = np.array([0.3, 0.3])
    with RrdWriter(tmp_path / "bad.rrd") as w, pytest.raises(ValueError, match="joint_angles"):
        w.log_event(msg)


def _layouts(path) -> list[set[str]]:
    """The view origins of each layout (blueprint) the recording holds."""
    reader = rr.chunk.RrdReader(path)
    layouts = []
    for store in reader.blueprints():
        origins = set()
        for chunk in reader.stream(store=store):
            batch = chunk.to_record_batch()
            if "ViewBlueprint:space_origin" in batch.schema.names:
                origins.update(o[0] for o in batch.column("ViewBlueprint:space_origin").to_pylist() if o)
        layouts.append(origins)
    return layouts


def test_the_layout_has_the_tabs_the_robots_roll_outs_fill(tmp_path):
    """No empty 3-D tabs ("Does not match any entity") for the 2-D point robot: a recording's
    layout has the views its events fill, a point robot's paths in (x, y), an arm's 3-D scene and
    joint curves."""
    point = tmp_path / "point.rrd"
    with RrdWriter(point) as w:
        for i in range(2):
            w.log_event(decode_event(encode(rollout_event("e1-0", i, np.zeros((5, 2)), np.linspace(0, 1, 5), np.zeros(5)))))
    layouts = _layouts(point)
    assert any("/trajectory/xy" in views for views in layouts)
    assert not any(views & {"/arm", "/trajectory/xyz", "/trajectory/time", "/latent_map"} for views in layouts)
    arm = tmp_path / "arm.rrd"
    with RrdWriter(arm) as w:
        w.log_event(_event(0, *_states(0), drawing="planar_chain"))
    layouts = _layouts(arm)
    assert any({"/arm", "/trajectory/time"} <= views for views in layouts)
    assert not any(views & {"/trajectory/xy", "/trajectory/xyz"} for views in layouts)
