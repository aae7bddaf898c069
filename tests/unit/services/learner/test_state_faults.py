"""A corrupt, missing or foreign state file never stops the learner, and never costs a version
number (issue 49, faults 1 and 2).

The table: every kind of file the learner keeps (a skill's checkpoint and demonstrations, a
paired skill's robot B checkpoint and demonstrations, a skill's version record, a job record and
its roll-out journal)
times every fault (truncated, garbage, deleted, of another format version, a half-written temp
file beside it). For each case a learner starts on a copy of one state directory: it comes up,
the healthy skills are served at their versions, the bad file is quarantined and named (in the
learner's health, hence ``acnmp status``), torch's ``weights_only=False`` advice appears nowhere,
the next version of the skill is above every number used before, and a second start finds
nothing more to quarantine.
"""
from __future__ import annotations

import json
import logging
import shutil

import numpy as np
import pytest
import torch

from acnmp_core.data.demo_io import demos_bytes
from acnmp_core.model.cnmp import CNMP, CNMPConfig
from acnmp_core.model.training import TrainConfig
from acnmp_core.tasks.viapoint.task import obstacle_demos
from services.learner.core import LearnerCore, TrainSpec
from services.learner.store import QUARANTINE, SkillState, demo_set_to_arrays
from services.recording.events import rollout_event
from services.transport.wire import decode, encode

SMALL = dict(encoder_widths=(8,), decoder_widths=(8,))
#: Kind of state file -> its path in the baseline directory, and the skill it belongs to.
FILES = {
    "checkpoint": ("skills/e1/model-v1.pt", "e1"),
    "demonstrations": ("skills/e1/demos-v1.npz", "e1"),
    "robot B checkpoint": ("skills/p/partner-v1.pt", "p"),
    "robot B demonstrations": ("skills/p/partner-demos-v1.npz", "p"),
    "version record": ("skills/e1/versions.json", "e1"),
    "job record": ("jobs/{job}.json", "e1"),
    "job journal": ("jobs/{job}.rollouts", "e1"),
}
FAULTS = ("truncate", "garbage", "delete", "wrong version", "half-written temp")
#: The version each skill is at in the baseline (e1 and p hold versions 0 and 1).
BASELINE = {"e1": 1, "e2": 0, "p": 1}


def _spec(steps: int = 1, seed: int = 0) -> TrainSpec:
    return TrainSpec(obstacle_demos(n_steps=20), CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=steps), seed=seed)


def _core(path) -> LearnerCore:
    return LearnerCore(path, evaluator_for=lambda job: None)


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    """A state directory with skills e1 (v0, v1), e2 (v0), paired p (v0, v1) and two job records: a
    done one that committed e1 v1 and a queued one. Returns (path, id of the done job)."""
    from acnmp_core.adaptation.config import AdaptConfig
    from acnmp_core.experiments.viapoint import make_setup
    from acnmp_core.jobs.adapt import AdaptJob

    path = tmp_path_factory.mktemp("state")
    core = _core(path)
    try:
        for skill in ("e1", "e1", "e2"):
            core.train_skill(skill, _spec())
        demos_b = obstacle_demos(n_steps=15)
        for version in (0, 1):
            model_a, model_b = CNMP(CNMPConfig(n_outputs=2, **SMALL)), CNMP(CNMPConfig(n_outputs=2, **SMALL))
            core.skill_store.save(SkillState("p", model_a, obstacle_demos(n_steps=20), core.skill_store.next_version("p"),
                                             partner=model_b, partner_demos=demos_b))
        setup = make_setup()
        request = AdaptJob(setup.target, "viapoint", "point2d", setup.task_config, AdaptConfig(max_rollouts=3))
        done = core.submit("e1", request)
        core._persist(done, state="done", committed_version=1)
        journalled = rollout_event(done.job, 0, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0])
        core.job_store.save_journal(done.job, [{**journalled, "attempt": 0}])
        core.submit("e2", request)
    finally:
        core.close()
    return path, done.job


def _wrong_version(path) -> None:
    """Rewrite ``path`` as the same file of a format version this learner does not read."""
    if path.suffix == ".pt":
        payload = torch.load(path, weights_only=True)
        payload["format"] = 2
        torch.save(payload, path)
    elif path.suffix == ".npz":
        data = dict(np.load(path))
        data["format_version"] = np.array(2)
        np.savez(path.with_suffix(""), **data)  # np.savez adds the .npz
    elif path.suffix == ".rollouts":
        path.write_bytes(encode({**decode(path.read_bytes(), expect_version=None), "v": 2}))
    else:
        body = json.loads(path.read_text())
        body["format"] = 2
        path.write_text(json.dumps(body))


def _apply(fault: str, path, rng: np.random.Generator) -> None:
    data = path.read_bytes()
    if fault == "truncate":
        path.write_bytes(data[: len(data) * 2 // 5])
    elif fault == "garbage":
        path.write_bytes(rng.bytes(len(data)))
    elif fault == "delete":
        path.unlink()
    elif fault == "wrong version":
        _wrong_version(path)
    else:  # a writer killed in the middle of replacing it (acnmp_core/files.py names its temp files so)
        path.with_name(f".{path.name}.k1ll3d.tmp").write_bytes(data[: len(data) // 2])


@pytest.mark.parametrize("fault", FAULTS)
@pytest.mark.parametrize("kind", list(FILES))
def test_a_bad_state_file_is_quarantined_and_everything_else_serves(kind, fault, baseline, tmp_path, caplog):
    base, done_job = baseline
    state = tmp_path / "state"
    shutil.copytree(base, state)
    rel, skill = FILES[kind]
    rel = rel.format(job=done_job)
    _apply(fault, state / rel, np.random.default_rng(list(FILES).index(kind) * len(FAULTS) + FAULTS.index(fault)))
    bad = fault in ("truncate", "garbage", "wrong version")

    with caplog.at_level(logging.INFO):
        core = _core(state)
    try:
        problems = core.health().problems()
        found = {q.path: q.reason for q in core.state.found}
        versions = {name: s.version for name, s in core.skills.items()}
        # the healthy skills, at their versions, and their models answer
        for name in ("e2", "p" if skill != "p" else "e1"):
            assert versions[name] == BASELINE[name], (versions, found)
        assert core.skills["e2"].model.predict(obs_times=[0.0], obs_values=[[0.0, 0.0]], n_steps=5).mean.shape == (5, 2)
        if bad:  # quarantined, named with its reason, and reported
            assert rel in found and found[rel], found
            assert not (state / rel).exists() or kind == "version record"  # that one is written again
            assert any(line.startswith(f"quarantined {rel}: ") for line in problems), problems
            assert list((state / QUARANTINE).rglob(rel.rsplit("/", 1)[-1])), "moved aside, not deleted"
        if fault == "half-written temp":
            assert not found and not problems and not list(state.rglob("*.tmp"))
        if kind in ("checkpoint", "demonstrations", "robot B checkpoint", "robot B demonstrations") \
                and fault in ("truncate", "garbage", "wrong version", "delete"):
            assert versions[skill] == BASELINE[skill] - 1  # the version before, never a retrain
            assert any(f"skill {skill}: version(s) 1 unusable" in n for n in core.skill_store.notes)
        else:
            assert versions[skill] == BASELINE[skill]
        if kind == "job record":
            assert (done_job in core.jobs) == (not bad and fault != "delete")
            assert len(core.jobs) >= 1  # the other record
        # no number is used twice: the next version is above every version ever committed
        any_model = core.skills["e2"]
        core._commit_skill(SkillState(skill, any_model.model, any_model.demos, core.skill_store.next_version(skill)))
        assert core.skills[skill].version == BASELINE[skill] + 1
    finally:
        core.close()
    assert "weights_only" not in caplog.text
    again = _core(state)  # the second start finds a consistent directory
    try:
        assert again.state.found == [] and again.skills[skill].version == BASELINE[skill] + 1
    finally:
        again.close()


#: What remembers that e1's version 1 was used, after its checkpoint was quarantined: every place the
#: learner counts (services/learner/store.py, "Versions are never reused"), or one of them alone.
KEPT = ("version record and quarantine", "version record", "quarantined files", "job record")


@pytest.mark.parametrize("kept", KEPT)
def test_a_restart_after_a_quarantine_never_reuses_the_quarantined_version_number(kept, baseline, tmp_path):
    """e1's version 1 is found unreadable at a start and quarantined (e1 is served at version 0);
    the learner stops and starts again, with every record of number 1 lost but ``kept`` (an
    operator emptied the quarantine, the version record was lost, the job that committed it was
    pruned); e1's next version is 2 all the same, never a second version 1."""
    base, done_job = baseline
    state = tmp_path / "state"
    shutil.copytree(base, state)
    (state / "skills/e1/model-v1.pt").write_bytes(np.random.default_rng(KEPT.index(kept)).bytes(4096))
    if kept != "job record":  # the done job whose record names version 1
        (state / f"jobs/{done_job}.json").unlink()
    core = _core(state)
    try:
        assert core.skills["e1"].version == 0 and "skills/e1/model-v1.pt" in {q.path for q in core.state.found}
    finally:
        core.close()
    if "version record" not in kept:
        (state / "skills/e1/versions.json").unlink()
    if kept not in ("version record and quarantine", "quarantined files"):
        shutil.rmtree(state / QUARANTINE)
    again = _core(state)
    try:
        assert again.skills["e1"].version == 0 and again.state.found == []
        assert again.train_skill("e1", _spec()).version == 2
    finally:
        again.close()
    again = _core(state)  # and the number is durable
    try:
        assert again.skills["e1"].version == 2
    finally:
        again.close()


@pytest.mark.parametrize("witness", ["version record", "job record"])
def test_a_deleted_newest_version_is_named_and_its_number_never_given_again(witness, baseline, tmp_path):
    """Issue 73, defect 3: every file of e1's newest version deleted by hand (``rm model-v1.pt
    demos-v1.npz``, and ``versions.json`` too when the job record alone remembers it): e1 is served
    at version 0 with a line in the learner's health naming version 1 as missing (so ``acnmp
    status`` exits 1), and the next version is 2; once version 2 is committed nothing is missing."""
    base, done_job = baseline
    state = tmp_path / "state"
    shutil.copytree(base, state)
    for name in ("model-v1.pt", "demos-v1.npz") + (("versions.json",) if witness == "job record" else ()):
        (state / "skills/e1" / name).unlink()
    if witness == "version record":  # the record alone remembers it (the job's was pruned)
        (state / f"jobs/{done_job}.json").unlink()
    says = "versions.json" if witness == "version record" else f"job {done_job}"
    core = _core(state)
    try:
        assert core.skills["e1"].version == 0 and core.state.found == []
        line = (f"skill e1: version(s) 1 missing (no file of it is left; {says} records it committed); serving "
                "version 0, the newest present; its next version will be 2")
        assert line in core.health().problems(), core.health().problems()
        assert core.train_skill("e1", _spec()).version == 2
    finally:
        core.close()
    again = _core(state)
    try:
        assert again.skills["e1"].version == 2 and again.health().problems() == []
    finally:
        again.close()


@pytest.mark.parametrize("case", ["checkpoint", "demonstrations", "job record"])
def test_a_readable_file_in_the_place_of_another_is_quarantined(case, tmp_path):
    """A well-formed file under another file's name (restored from the wrong backup, copied by
    hand): version 0's checkpoint or demonstrations as version 1's, a job's record under another
    job's id. Each is quarantined, saying whose it is; the rest serves as before."""
    core = _core(tmp_path)
    core.train_skill("e1", _spec())
    core.train_skill("e1", TrainSpec(obstacle_demos(n_steps=15), CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=1)))
    core.close()
    d = tmp_path / "skills/e1"
    jobs = tmp_path / "jobs"
    if case == "job record":
        from acnmp_core.experiments.viapoint import make_setup
        from acnmp_core.jobs.adapt import AdaptJob

        setup = make_setup()
        core = _core(tmp_path)
        job = core.submit("e1", AdaptJob(setup.target, "viapoint", "point2d", setup.task_config)).job
        core.close()
        rel, bad = "jobs/e1-0123456789.json", f"holds job {job!r}, its name says 'e1-0123456789'"
        shutil.copy(jobs / f"{job}.json", tmp_path / rel)
    else:
        name = {"checkpoint": "model-v{}.pt", "demonstrations": "demos-v{}.npz"}[case]
        rel = f"skills/e1/{name.format(1)}"
        shutil.copy(d / name.format(0), tmp_path / rel)
        bad = ("holds skill 'e1' version 0, its name says e1 version 1" if case == "checkpoint"
               else "does not match the data hash that model-v1.pt records")
    core = _core(tmp_path)
    try:
        found = {q.path: q.reason for q in core.state.found}
        assert found.get(rel) == bad, found
        if case == "job record":
            assert list(core.jobs) == [job]
        else:
            assert core.skills["e1"].version == 0 and core.train_skill("e1", _spec()).version == 2
    finally:
        core.close()


def test_a_file_of_another_kind_in_place_of_a_checkpoint_is_named_without_torchs_advice(tmp_path):
    """Torch's own message for a file it cannot load safely suggests ``weights_only=False``, which
    would let a file of unknown origin run code; the learner says what the file is not instead."""
    core = _core(tmp_path)
    core.train_skill("e1", _spec())
    core.close()
    (tmp_path / "skills/e1/model-v0.pt").write_bytes(b"\x80\x04\x95" + bytes(range(256)) * 20)  # a pickle, not torch
    core = _core(tmp_path)
    try:
        note, demos, line = core.health().problems()  # what is served now, the demonstrations its checkpoint named, and it
        assert note.startswith("skill e1: no usable version (version(s) 0 quarantined)"), note
        assert demos.startswith("quarantined skills/e1/demos-v0.npz: part of version 0 of skill e1")
        assert line.startswith("quarantined skills/e1/model-v0.pt: not a readable checkpoint (truncated or not a "
                               "torch file) (moved to quarantine/") and "weights_only" not in line
        assert "e1" not in core.skills
        assert core.train_skill("e1", _spec()).version == 1  # 0 was used
    finally:
        core.close()


def test_the_old_layout_is_read_and_moved_to_one_checkpoint_per_version(tmp_path):
    """A state directory written before versions had their own checkpoints (skills/<s>/model.pt
    naming demos-v<N>.npz) loads at its version; its next version is N + 1."""
    core = _core(tmp_path)
    core.train_skill("e1", _spec())
    core.train_skill("e1", _spec())
    core.close()
    d = tmp_path / "skills/e1"
    (d / "model-v1.pt").rename(d / "model.pt")
    for old in ("model-v0.pt", "demos-v0.npz", "versions.json"):
        (d / old).unlink()
    core = _core(tmp_path)
    try:
        assert core.skills["e1"].version == 1 and core.state.found == []
        assert (d / "model-v1.pt").exists() and not (d / "model.pt").exists()
        assert core.train_skill("e1", _spec()).version == 2
    finally:
        core.close()


def test_a_commit_cut_short_before_its_checkpoint_is_cleaned_up_not_quarantined(tmp_path):
    """A kill between a new version's demonstrations and its checkpoint leaves demonstrations no
    checkpoint names, of a version the version record never saw: they are removed, not reported."""
    core = _core(tmp_path)
    state = core.train_skill("e1", _spec())
    core.close()
    d = tmp_path / "skills/e1"
    (d / "demos-v1.npz").write_bytes(demos_bytes(demo_set_to_arrays(state.demos)))
    core = _core(tmp_path)
    try:
        assert core.state.found == [] and not (d / "demos-v1.npz").exists() and core.skills["e1"].version == 0
    finally:
        core.close()


def test_the_newest_versions_are_kept_and_older_ones_removed(tmp_path):
    from services.learner.limits import StateLimits

    core = LearnerCore(tmp_path, evaluator_for=lambda job: None, state_limits=StateLimits(keep_versions=2))
    try:
        for _ in range(4):
            core.train_skill("e1", _spec())
    finally:
        core.close()
    names = sorted(p.name for p in (tmp_path / "skills/e1").iterdir())
    assert names == ["demos-v2.npz", "demos-v3.npz", "model-v2.pt", "model-v3.pt", "versions.json"]
    assert json.loads((tmp_path / "skills/e1/versions.json").read_text())["highest"] == 3


def test_an_unreadable_default_demonstration_file_is_quarantined_and_written_again(tmp_path):
    from clients.default_skill import default_demos

    spec = default_demos(tmp_path)
    path = tmp_path / "e1-demos.npz"
    good = path.read_bytes()
    path.write_bytes(good[:100])
    assert default_demos(tmp_path) == spec and path.read_bytes() == good
    moved, = [p for p in (tmp_path / QUARANTINE).rglob("e1-demos.npz")]
    assert "truncated" in moved.with_name("e1-demos.npz.why").read_text()
