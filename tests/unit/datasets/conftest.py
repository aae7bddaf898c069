"""Fixtures of the dataset tests: the formats' own libraries, imported as a user would, and a
private Minari datasets root."""
from __future__ import annotations

import importlib
import sys
import types

import pytest


@pytest.fixture
def minari_root(tmp_path, monkeypatch):
    """$MINARI_DATASETS_PATH pointed at a directory of this test (minari and the project read it)."""
    root = tmp_path / "minari"
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(root))
    return root


@pytest.fixture(scope="session")
def lerobot():
    """lerobot-dataset's ``ledataset.datasets`` modules (the ``datasets`` extra: pip install
    -e .[datasets]); its LeRobotDataset is ``lerobot.lerobot_dataset.LeRobotDataset``.

    lerobot imports torchvision at module level, for images and videos only. PyPI's torchvision
    for this machine's CPU build of torch is a CUDA build that does not load beside it, so when
    torchvision cannot be imported a stand-in module is registered: the datasets here have no image
    or video features, and nothing of torchvision runs for them."""
    import os

    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    try:
        import torchvision  # noqa: F401
    except Exception:
        for name in [m for m in sys.modules if m.startswith("torchvision")]:
            del sys.modules[name]
        import datasets  # noqa: F401  (it notes torchvision's absence before the stand-in exists)

        stub = types.ModuleType("torchvision")
        stub.transforms = types.ModuleType("torchvision.transforms")
        stub.io = types.ModuleType("torchvision.io")
        sys.modules.update({"torchvision": stub, "torchvision.transforms": stub.transforms,
                            "torchvision.io": stub.io})
    lerobot_dataset = importlib.import_module("ledataset.datasets.lerobot_dataset")
    utils = importlib.import_module("ledataset.datasets.utils")
    return types.SimpleNamespace(lerobot_dataset=lerobot_dataset, utils=utils)


@pytest.fixture
def recording(tmp_path):
    """(path, rows): a recording of 6 E1 roll-outs (every other one marked successful), written as the learner
    records them, and its roll-out rows as services.recording.tables reads them back."""
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
    path = tmp_path / "e1.rrd"
    writer = RrdWriter(path)
    writer.log_event(job_event("e1-acnmp-0", method="acnmp", robot="point2d", task="viapoint", skill="e1", seed=0,
                               attempt=0, config={}, task_config=setup.task_config))
    for ev in batch_rollout_events("e1-acnmp-0", 0, paths, times, batch, skill="e1", iteration=0,
                                   task_params=rng.normal(size=(len(paths), 2))):
        ev["attempt"] = 0
        ev["success"] = ev["rollout_index"] % 2 == 0  # both kinds, whatever the task made of them
        writer.log_event(ev)
    writer.close()
    rows = read_recording(path).rollout_rows()
    assert 0 < sum(r["success"] for r in rows) < len(rows), "the fixture wants both kinds of roll-out"
    return path, rows
