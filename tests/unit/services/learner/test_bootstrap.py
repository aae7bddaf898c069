"""`--demos SKILL=FILE.npz` at the learner's start (issue 36, row 2): a skill already in the state
directory was kept even when FILE held other demonstrations; now it is retrained from them (and
said so), and kept when it was trained from them, assimilated since or not."""
from __future__ import annotations

import logging

import numpy as np

from acnmp_core.data.demo_io import save_demos
from acnmp_core.data.demos import DemoSet, Demonstration
from acnmp_core.tasks.viapoint.task import obstacle_demos
from services.learner.core import LearnerCore
from services.learner.service import bootstrap
from services.learner.store import SkillState, SkillStore, demo_set_to_arrays

STEPS = 5


def _core(state_dir) -> LearnerCore:
    return LearnerCore(state_dir, evaluator_for=lambda job: None)


def _file(path, shift: float = 0.0) -> str:
    demos = obstacle_demos(n_steps=30)
    demos = DemoSet([Demonstration(d.times, d.values + shift, d.task_params) for d in demos])
    save_demos(path, demo_set_to_arrays(demos))
    return f"mine={path}"


def test_a_changed_demonstration_file_retrains_the_skill_and_the_same_one_keeps_it(tmp_path, caplog):
    state = tmp_path / "state"
    old_spec, new_spec = _file(tmp_path / "old.npz"), _file(tmp_path / "new.npz", shift=0.25)
    core = _core(state)
    try:
        assert bootstrap(core, [old_spec], STEPS) == [f"skill mine: version 0 trained from {tmp_path / 'old.npz'}"]
        first = core.skills["mine"]
        assert "kept" in bootstrap(core, [old_spec], STEPS)[0] and core.skills["mine"] is first
    finally:
        core.close()
    core = _core(state)  # a restart (`acnmp up --demos mine=NEW.npz` on the same state directory)
    try:
        with caplog.at_level(logging.WARNING, logger="services.learner.service"):
            line, = bootstrap(core, [new_spec], STEPS)
        assert "retrained" in line and core.skills["mine"].version == 1
        assert "retraining it from" in caplog.text and str(tmp_path / "new.npz") in caplog.text
        assert np.allclose(core.skills["mine"].demos[0].values, first.demos[0].values + 0.25)
    finally:
        core.close()
    core = _core(state)  # the source is remembered across restarts: the new file is no change now
    try:
        assert "kept" in bootstrap(core, [new_spec], STEPS)[0] and core.skills["mine"].version == 1
    finally:
        core.close()


def test_an_assimilated_skill_is_kept_for_the_file_it_was_trained_from(tmp_path):
    spec = _file(tmp_path / "d.npz")
    core = _core(tmp_path / "state")
    try:
        bootstrap(core, [spec], STEPS)
        s = core.skills["mine"]
        extra = Demonstration(s.demos[0].times, s.demos[0].values + 1.0, s.demos[0].task_params)
        grown = DemoSet([*s.demos, extra])  # what an assimilation commits: the demos plus a solution
        for source in (s.source_hash, None):  # recorded, or a skill saved before it was recorded
            SkillStore(tmp_path / "state").save(SkillState("mine", s.model, grown, 7, source_hash=source))
            core.skills = SkillStore(tmp_path / "state").load_all()
            assert core.skills["mine"].source_hash == source
            assert "kept" in bootstrap(core, [spec], STEPS)[0] and core.skills["mine"].version == 7
    finally:
        core.close()


def test_a_stop_interrupts_training_and_assimilation_at_their_next_step(tmp_path, e1_demos):
    """Issue 36, row 10: a learner told to stop kept training (a first start's skill, a train
    request, an assimilation) until the launcher SIGKILLed it; each now ends at its next step."""
    import threading

    import pytest

    from acnmp_core.adaptation.assimilation import AssimilationConfig, assimilate
    from acnmp_core.model.cnmp import CNMP, CNMPConfig
    from acnmp_core.model.training import TrainConfig, train

    stop = threading.Event()
    stop.set()
    with pytest.raises(InterruptedError):
        train(CNMP(CNMPConfig(n_outputs=2)), e1_demos, TrainConfig(steps=10**7), progress=False, stop=stop)
    model = CNMP(CNMPConfig(n_outputs=2, prior="none"))
    model.fit_normalization(e1_demos)
    with pytest.raises(InterruptedError):
        assimilate(model, e1_demos, e1_demos[0], AssimilationConfig(steps=10**7), stop=stop)
    core = _core(tmp_path / "state")
    try:
        core.interrupt()
        with pytest.raises(InterruptedError):
            bootstrap(core, [_file(tmp_path / "d.npz")], 10**7)
        assert core.skills == {}  # nothing half-trained committed
    finally:
        core.close()
