"""The learner never pretends (issue 49, faults 3 to 5): a job is accepted and a cancel answered
only once on disk; a full disk fails the job it hits with a message that says so, the job loop
waits for space and runs the next job, memory and disk agree after a restart, and terminal states
stay terminal; the queue is bounded (``busy``) and finished records are pruned.

The full-disk scenario runs twice: on a real small file system (a tmpfs this test mounts and
always unmounts; skipped with one line where it cannot mount one) and on a disk faked by making
every state write fail with ``ENOSPC`` (so the logic is checked everywhere).
"""
from __future__ import annotations

import errno
import os
import subprocess
import time
import tracemalloc

import numpy as np
import pytest

from acnmp_core.adaptation.config import AdaptConfig
from acnmp_core.experiments.viapoint import make_setup
from acnmp_core.jobs.adapt import AdaptJob
from acnmp_core.model.cnmp import CNMPConfig
from acnmp_core.model.training import TrainConfig
from acnmp_core.tasks.viapoint.task import obstacle_demos
from services.learner import store
from services.learner.core import LearnerBusy, LearnerCore, TrainSpec
from services.learner.limits import StateLimits
from services.learner.store import StateWriteError
from services.worker.core import ExecutedBatch

SMALL = dict(encoder_widths=(8,), decoder_widths=(8,))


@pytest.fixture(scope="module")
def setup():
    return make_setup()


class Scripted:
    """An evaluator whose every roll-out succeeds (so a committing job assimilates); ``before(n)``
    runs before its n-th batch (1-based)."""

    def __init__(self, before=lambda n: None):
        self.calls, self.before = 0, before

    def evaluate(self, trajectories, times, task_params=None):
        self.calls += 1
        self.before(self.calls)
        b, t = trajectories.shape[:2]
        return ExecutedBatch(np.zeros((b, t)), np.ones(b, dtype=bool), workers=("w0",) * b)


class FakeDisk:
    """A state directory whose writes fail with ENOSPC while ``full`` (the library's own writer,
    as the learner calls it, raises what a full file system raises)."""

    def __init__(self, path, monkeypatch):
        self.path, self.full = path, False
        real = store.atomic_write_bytes

        def write(target, data, **kw):
            if self.full:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(target))
            return real(target, data, **kw)

        monkeypatch.setattr(store, "atomic_write_bytes", write)

    def fill(self) -> None:
        self.full = True

    def free(self) -> None:
        self.full = False


class Tmpfs:
    """A 4 MiB tmpfs mounted at ``path``; ``fill`` writes a filler file until the file system
    refuses, ``free`` removes it."""

    def __init__(self, path):
        self.path = path
        path.mkdir()
        out = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs", str(path)], capture_output=True,
                             text=True)
        if out.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {out.stderr.strip() or out.returncode}")
        self.filler = path / "filler"

    def fill(self) -> None:
        fd = os.open(self.filler, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
        try:
            for chunk in (1 << 16, 1 << 12, 1):  # down to the last byte a page can hold
                try:
                    while True:
                        os.write(fd, b"\0" * chunk)
                except OSError as exc:
                    assert exc.errno == errno.ENOSPC, exc
        finally:
            os.close(fd)

    def free(self) -> None:
        self.filler.unlink()

    def unmount(self) -> None:
        subprocess.run(["umount", str(self.path)], check=True)


@pytest.fixture(params=["tmpfs", "fake"])
def disk(request, tmp_path, monkeypatch):
    if request.param == "fake":
        yield FakeDisk(tmp_path / "state", monkeypatch)
        return
    fs = Tmpfs(tmp_path / "fs")
    try:
        yield fs
    finally:
        fs.unmount()


def _request(setup, seed: int, **config) -> AdaptJob:
    """A committing job of one batch (5 roll-outs) unless ``config`` says otherwise."""
    cfg = AdaptConfig(**{"max_rollouts": 5, "noisy_per_iter": 4, **config})
    return AdaptJob(setup.target, "viapoint", "point2d", setup.task_config, cfg, seed=seed, commit=True,
                    assimilate_steps=5)


def _until(condition, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < end, "timed out"
        time.sleep(0.02)


def test_a_full_disk_fails_the_job_it_hits_says_so_and_the_loop_runs_the_next(disk, setup):
    evaluators = {}
    core = LearnerCore(disk.path, evaluator_for=lambda req: evaluators[req.seed])
    try:
        core.train_skill("e1", TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=1)))
        # accepted only once on disk: on a full disk a submit and a cancel are refused, nothing changes
        waiting = core.submit("e1", _request(setup, 0))
        disk.fill()
        with pytest.raises(StateWriteError, match=r"^no space left on device while saving job e1-\w+ to .*\.json$"):
            core.submit("e1", _request(setup, 1))
        with pytest.raises(StateWriteError, match=f"no space left on device while saving job {waiting.job}"):
            core.cancel(waiting.job)
        assert list(core.jobs) == [waiting.job] and len(os.listdir(core.job_store.root)) == 1
        assert core.status(waiting.job)["state"] == "queued" and not core.status(waiting.job)["cancel_requested"]
        assert core.health().problems() == [f"cannot write its state: {core.state.write_error}"]
        disk.free()
        assert core.cancel(waiting.job)["state"] == "cancelled"

        # during an adaptation: its second iteration cannot journal (then reserve) its roll-outs
        evaluators[1] = Scripted(before=lambda n: n == 2 and disk.fill())
        evaluators[2] = Scripted()
        adapting = core.submit("e1", _request(setup, 1, max_rollouts=10, stop_on_success=False))
        after = core.submit("e1", _request(setup, 2))
        core.start()
        _until(lambda: core.health().write_error is not None)
        # its failure is not shown before it is on disk: the record still says running
        assert core.status(adapting.job)["state"] == "running" and core.status(after.job)["state"] == "queued"
        assert core.health().loop_running
        disk.free()
        assert core.wait_idle(60)
        failed = core.status(adapting.job)
        assert failed["state"] == "failed" and failed["error"].startswith(
            f"no space left on device while saving the roll-out journal of job {adapting.job} to "), failed["error"]
        assert core.status(after.job)["state"] == "done" and core.skills["e1"].version == 1

        # during an assimilation: the new version's files cannot be written; nothing is committed
        evaluators[3], evaluators[4] = Scripted(), Scripted()
        real_save = core.skill_store.save

        def save_on_a_full_disk(state):
            disk.fill()
            core.skill_store.save = real_save
            return real_save(state)

        core.skill_store.save = save_on_a_full_disk
        assimilating = core.submit("e1", _request(setup, 3))
        _until(lambda: core.health().write_error is not None)
        disk.free()
        assert core.wait_idle(60)
        failed = core.status(assimilating.job)
        skills = core.state.root / "skills" / "e1"
        assert failed["state"] == "failed" and failed["error"] == (
            f"no space left on device while saving skill e1 version 2 to {skills / 'demos-v2.npz'}")
        assert core.skills["e1"].version == 1 and not list(skills.glob("*-v2.*"))
        last = core.submit("e1", _request(setup, 4))
        assert core.wait_idle(60)
        assert core.status(last.job)["committed_version"] == core.skills["e1"].version == 3
        assert core.health().problems() == []
        seen = core.list_jobs(1000)
    finally:
        core.close()
    again = LearnerCore(disk.path, evaluator_for=lambda req: Scripted())
    try:  # memory and disk agree: the same states, terminal ones terminal, nothing runs again
        assert again.list_jobs(1000) == seen
        assert again.skills["e1"].version == 3 and again.health().problems() == []
    finally:
        again.close()


def test_the_queue_limit_refuses_with_busy_and_memory_stays_bounded_over_10000_submissions(tmp_path, setup):
    limits = StateLimits(max_queued_jobs=20, keep_finished_jobs=30)
    core = LearnerCore(tmp_path, evaluator_for=lambda req: Scripted(), state_limits=limits)  # not started
    try:
        core.train_skill("e1", TrainSpec(obstacle_demos(n_steps=20), CNMPConfig(n_outputs=2, **SMALL),
                                          TrainConfig(steps=1)))
        request = _request(setup, 0)
        accepted, refused, message = 0, 0, ""
        tracemalloc.start()
        try:
            for i in range(10_000):
                try:
                    core.submit("e1", request)
                    accepted += 1
                except LearnerBusy as exc:
                    refused, message = refused + 1, str(exc)
                if i % 2500 == 2499:  # the queued jobs end (cancelled): room for 20 more
                    for job in [j for j in core.jobs.values() if j.state == "queued"]:
                        core.cancel(job.job)
                if i == 2500:
                    early = tracemalloc.take_snapshot()
            grown = sum(s.size_diff for s in tracemalloc.take_snapshot().compare_to(early, "filename"))
        finally:
            tracemalloc.stop()
        assert accepted == 80 and refused == 10_000 - 80
        assert message == ("the learner already holds 20 unfinished jobs, its limit (--max-queued-jobs 20); nothing "
                           "was queued: send it again once some have finished")
        # every accepted job ended (cancelled): the newest 30 records are kept, exactly
        assert len(core.jobs) == 30 and len(list(core.job_store.root.iterdir())) == len(core.jobs)
        assert grown < 256 * 1024, grown  # 7500 submissions later: no more than a few records' worth
    finally:
        core.close()


def test_finished_job_records_are_pruned_by_age(tmp_path, setup):
    core = LearnerCore(tmp_path, evaluator_for=lambda req: Scripted(), state_limits=StateLimits(keep_finished_days=1))
    try:
        core.train_skill("e1", TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=1)))
        old, recent = core.submit("e1", _request(setup, 0)), core.submit("e1", _request(setup, 1))
        core.cancel(old.job)
        core._persist(old, created=time.time() - 3 * 86400)
        old.updated = time.time() - 2 * 86400  # as if it ended two days ago
        core.cancel(recent.job)  # a job ending prunes
        assert list(core.jobs) == [recent.job] and not core.job_store.path(old.job).exists()
    finally:
        core.close()


def test_exactly_keep_jobs_finished_records_are_kept_the_newest(tmp_path, setup):
    """``--keep-jobs 2``: after each job ends, the records of the two newest finished jobs stay (in
    memory, on disk, after a restart), an unfinished one is never pruned."""
    limits = StateLimits(keep_finished_jobs=2)
    core = LearnerCore(tmp_path, evaluator_for=lambda req: Scripted(), state_limits=limits)  # not started
    try:
        core.train_skill("e1", TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=1)))
        jobs = [core.submit("e1", _request(setup, seed)).job for seed in range(5)]
        for n, job in enumerate(jobs[:4], start=1):
            core.cancel(job)
            kept = jobs[max(0, n - 2):]  # the two newest finished ones, and the queued ones
            assert list(core.jobs) == kept, n
            assert sorted(p.stem for p in core.job_store.root.glob("*.json")) == sorted(kept)
    finally:
        core.close()
    again = LearnerCore(tmp_path, evaluator_for=lambda req: Scripted(), state_limits=limits)
    try:
        assert list(again.jobs) == jobs[2:]
    finally:
        again.close()


def test_a_commit_whose_checkpoint_cannot_be_written_leaves_nothing_of_its_version(tmp_path, monkeypatch, setup):
    """The checkpoint is a version's commit point: when it cannot be written, the demonstrations
    already written for that version are removed again, and the skill stays as it was."""
    core = LearnerCore(tmp_path, evaluator_for=lambda req: Scripted())
    try:
        spec = TrainSpec(setup.demos, CNMPConfig(n_outputs=2, **SMALL), TrainConfig(steps=1))
        core.train_skill("e1", spec)
        real = store.atomic_write_bytes

        def write(target, data, **kw):  # the disk fills up between the demonstrations and the checkpoint
            if os.path.basename(target) == "model-v1.pt":
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(target))
            return real(target, data, **kw)

        monkeypatch.setattr(store, "atomic_write_bytes", write)
        with pytest.raises(StateWriteError, match=r"while saving skill e1 version 1 to .*model-v1\.pt$"):
            core.train_skill("e1", spec)
        assert core.skills["e1"].version == 0
        assert sorted(os.listdir(core.state.root / "skills" / "e1")) == ["demos-v0.npz", "model-v0.pt", "versions.json"]
    finally:
        core.close()
