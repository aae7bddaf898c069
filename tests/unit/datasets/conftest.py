"""Fixtures of the dataset tests: a private Minari datasets root and a small recording (the
``lerobot`` fixture, lerobot imported as a user would, is in tests/conftest.py)."""
from __future__ import annotations

import pytest

#: the names of the recorded skill's outputs and task parameters (a learner's job event carries them)
SKILL_NAMES, SKILL_PARAM_NAMES = ("x", "y"), ("via_x", "via_y")


@pytest.fixture
def minari_root(tmp_path, monkeypatch):
    """$MINARI_DATASETS_PATH pointed at a directory of this test (minari and the project read it)."""
    root = tmp_path / "minari"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    return root


@pytest.fixture(scope="session")
def recording(tmp_path_factory):
    """(path, rows): a recording of 6 E1 roll-outs (every other one marked successful), written as the learner
    records them (its job named with the skill's names :data:`SKILL_NAMES` and :data:`SKILL_PARAM_NAMES`), and
    its roll-out rows as services.recording.tables reads them back."""
    import numpy as np

    from acnmp_core.experiments.viapoint import make_setup
    from services.recording.events import batch_rollout_events, job_event
    from services.recording.rrd_writer import RrdWriter
    from services.recording.tables import read_recording

    setup = make_setup()
    times = setup.target.query_times
    demo = np.stack([np.interp(times, d.times, d.values[:, j]) for d in setup.demos[:1] for j in range(2)], axis=1)
    rng = np.random.default_rng(1)
    paths = np.stack([demo + rng.normal(scale=s, size=demo.shape) for s in (0, 0.3, 0, 0.3, 0.001, 0.3)])
    batch = setup.task.evaluate(paths, times, None)
    path = tmp_path_factory.mktemp("recording") / "e1.rrd"
    writer = RrdWriter(path)
    writer.log_event(job_event("e1-acnmp-0", method="acnmp", robot="point2d", task="viapoint", skill="e1", seed=0,
                               attempt=0, config={}, task_config=setup.task_config, output_names=SKILL_NAMES,
                               task_param_names=SKILL_PARAM_NAMES))
    for ev in batch_rollout_events("e1-acnmp-0", 0, paths, times, batch, skill="e1", iteration=0,
                                   task_params=rng.normal(size=(len(paths), 2))):
        ev["attempt"] = 0
        ev["success"] = ev["rollout_index"] % 2 == 0  # both kinds, whatever the task made of them
        writer.log_event(ev)
    writer.close()
    rows = read_recording(path).rollout_rows()
    assert 0 < sum(r["success"] for r in rows) < len(rows), "the fixture wants both kinds of roll-out"
    return path, rows
