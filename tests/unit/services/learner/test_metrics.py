"""The learner is not silent: its loss curve while training and its return and exploration per
adaptation iteration go to the recording as ``metrics`` events (Scalars in the viewer, a line in
``acnmp replay``) and to stderr as one line every few seconds."""
from __future__ import annotations

import logging

import pytest

from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.jobs.adapt import AdaptJob
from acnmp_core.model.cnmp import CNMPConfig
from acnmp_core.model.training import TrainConfig
from services.learner.core import LearnerCore, TrainSpec
from services.learner.metrics import MetricsReporter
from services.recording.events import metric_values, metrics_event, validate_event
from services.recording.replay import format_summary, summarize
from services.recording.rrd_writer import RrdWriter
from services.transport import WireError
from services.worker.core import ExecutedBatch


class InProcess:
    def __init__(self, task):
        self.task = task

    def evaluate(self, trajectories, times, task_params=None):
        return ExecutedBatch.of(self.task.evaluate(trajectories, times, task_params), ["w0"] * len(trajectories))


def test_training_and_adaptation_publish_their_curves_and_log_lines(tmp_path, caplog):
    setup = make_setup()
    events = []
    core = LearnerCore(tmp_path, evaluator_for=lambda job: InProcess(setup.task), publish=events.append).start()
    caplog.set_level(logging.INFO, logger="services.learner")
    try:
        spec = TrainSpec(setup.demos, CNMPConfig(n_outputs=2, encoder_widths=(32,), decoder_widths=(32,)),
                         TrainConfig(steps=300, val_every=100), seed=3)
        core.train_skill("e1", spec)
        job = core.submit("e1", AdaptJob(setup.target, "viapoint", "point2d", setup.task_config,
                                         AdaptConfig(max_rollouts=9, max_reuse=5, stop_on_success=False), seed=5))
        assert core.wait_idle(120)
    finally:
        core.close()
    metrics = [e for e in events if e["kind"] == "metrics"]
    assert all(validate_event(e) is e for e in metrics)
    train = [e for e in metrics if e["phase"] == "train"]
    assert [(e["source"], e["step"]) for e in train] == [("e1", 100), ("e1", 200), ("e1", 300)]
    assert all(set(metric_values(e)) == {"nll", "val_nll"} for e in train)
    adapt = [e for e in metrics if e["phase"] == "adapt"]
    assert [e["source"] for e in adapt] == [job.job] * len(adapt) and len(adapt) >= 2
    assert [e["step"] for e in adapt] == list(range(len(adapt)))
    assert adapt[-1]["rollouts"] == 9.0 and {"mean_return", "best_return", "explore_std"} <= set(adapt[-1])
    lines = [r.getMessage() for r in caplog.records if r.name == "services.learner"]
    # the first and the last point of each curve print; the ones between only every 5 s
    assert "skill e1: training step 100/300" in lines[0] and any("training step 300/300" in x for x in lines)
    assert any(x.startswith(f"job {job.job}: iteration 0, ") for x in lines)


def test_the_stderr_line_comes_every_few_seconds_per_source():
    published, now = [], [0.0]
    reporter = MetricsReporter(published.append, every=5.0, clock=lambda: now[0])
    logged = []
    handler = logging.Handler()
    handler.emit = lambda record: logged.append(record.getMessage())
    logger = logging.getLogger("services.learner")
    logger.addHandler(handler)
    old = logger.level
    logger.setLevel(logging.INFO)
    try:
        for step in range(10):  # one point a second
            now[0] = float(step)
            reporter.report("e1", "train", step, {"nll": 1.0 / (step + 1)}, f"line {step}", last=step == 9)
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old)
    assert len(published) == 10
    assert logged == ["line 0", "line 5", "line 9"]


def test_metrics_events_are_checked():
    ev = metrics_event("e1-0123456789", "adapt", 3, {"mean_return": -0.5, "explore_std": None})
    assert metric_values(ev) == {"mean_return": -0.5}
    for bad in ({**ev, "phase": "dream"}, {**ev, "mean_return": float("nan")}, {**ev, "step": -1},
                {**ev, "mean_return": "high"}):
        with pytest.raises(WireError):
            validate_event(bad)
    with pytest.raises(ValueError, match="clashes"):
        metrics_event("e1", "train", 0, {"step": 1.0})


def test_metrics_are_time_series_in_the_recording_and_summarised_by_replay(tmp_path):
    path = tmp_path / "m.rrd"
    writer = RrdWriter(path)
    for step, (nll, val) in zip((250, 500, 750), ((1.0, 1.2), (0.5, 0.7), (0.2, 0.4))):
        writer.log_event(metrics_event("e1", "train", step, {"nll": nll, "val_nll": val}))
    writer.log_event(metrics_event("e1-0123456789", "adapt", 0, {"mean_return": -1.0}))
    writer.close()
    s = summarize(path)
    assert s["events"]["metrics"] == 4
    assert s["metrics"]["e1"]["train/nll"] == {"points": 3, "first_step": 250, "last_step": 750, "first": 1.0,
                                               "last": 0.2, "min": 0.2, "max": 1.0}
    assert s["metrics"]["e1-0123456789"]["adapt/mean_return"]["points"] == 1
    text = format_summary(s)
    assert "learner metrics of e1 (to step 750): train/nll 1 -> 0.2, train/val_nll 1.2 -> 0.4" in text
