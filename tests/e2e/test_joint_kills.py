"""Nothing lost when the learner dies together with the recorder, or with the recorder and the
launcher (issue 73, defect 1), through the fault-point harness of bench_faults.py.

A learner life kills itself with SIGKILL at a point between writing a batch's journal and its
roll-outs reaching the recorder (benchmarks/performance/fault_points.py: journalled, reserved,
publishing, published), at its 3rd batch, and kills the recorder (or the launcher and the
recorder) at the same moment. The recorder writes its file late (Rerun's flush tick set to 5 s
instead of 0.2 s: a busy disk), so what it had received is in no file when it dies. Before, a
journal kept the job's last two batches only: the batches before them were lost at such kills
(50 of 460 reserved roll-outs). Now a roll-out leaves the journal only once the recorder says its
file holds it, and every reserved index is in the recording exactly once.
"""
from __future__ import annotations

import pytest

from benchmarks.performance.bench_faults import part_kills
from benchmarks.performance.fault_points import ENV

#: Who dies with the learner, at which point, in each killed life (then a life runs the jobs to their end).
LIVES = [{"point": point, "batch": 3, "with": list(who), "launcher_after": False}
         for point, who in (("published", ("recorder",)), ("publishing", ("launcher", "recorder")),
                            ("journalled", ("recorder",)), ("reserved", ("launcher", "recorder")))]


@pytest.mark.slow  # a minute of kills and restarts; tests/unit/services/learner/test_journal.py keeps the rule
def test_every_reserved_rollout_is_recorded_once_when_the_learner_dies_with_the_recorder(tmp_path):
    counts = part_kills(LIVES, jobs=1, budget=120, tmp=tmp_path, env=dict(ENV, RERUN_FLUSH_TICK_SECS="5"))
    (job,) = counts["per_job"].values()
    assert job["state"] == "done" and job["attempts"] == len(LIVES) + 1, job
    assert counts["lost"] == 0 and counts["duplicated"] == 0, counts
    assert job["reserved"] > 120  # the killed attempts' roll-outs are reserved and recorded too
    assert counts["excluded_at_end"] == 0  # workers going down with their launcher are no attempt's fault
