"""A recording is never truncated by a restart (issue 66: `acnmp up --record r.rrd` started again
with the same path cut a recording of 100 roll-outs to 10). A deployment started on an existing
recording continues it in its next segment, ``r.1.rrd``, the same Rerun recording (application and
recording id), and a roll-out the earlier segment holds, published again (a learner's journal after
a kill), is not written twice; ``acnmp replay r.rrd`` reads the segments together. A file there
that is not an ACNMP recording is refused with one line before anything starts."""
from __future__ import annotations

import numpy as np
import pytest

from clients.commands.up import stopping_line
from services.launcher import LocalDeployment
from services.recording.events import rollout_event
from services.recording.replay import summarize
from services.recording.tables import read_recording
from services.transport import call

JOB = "e1-0123456789"
TIMES = np.linspace(0.0, 1.0, 10)


def _session(rrd, state, first: int, n: int) -> tuple[LocalDeployment, dict, str]:
    """A recorder-only deployment on ``rrd`` publishing roll-outs ``first``..``first+n-1`` of
    :data:`JOB` as a learner does (with ``attempt``), until its recorder holds them; with its
    recorder's status and the line ``acnmp up`` prints as it stops it."""
    with LocalDeployment("segments", workers=0, model=False, learner=False, record=rrd, state_dir=state) as dep:
        for i in range(first, first + n):
            ev = rollout_event(JOB, i, np.zeros((len(TIMES), 2)) + i, TIMES, -np.ones(len(TIMES)), worker="w0")
            dep.events.publish({**ev, "attempt": 0})
        assert dep.events.wait_recorded(30)
        status = call(dep.session, dep.keys.recorder_status(), timeout=10)
        stopping = stopping_line(dep)
    return dep, status, stopping


def test_a_deployment_started_again_on_its_recording_continues_it_in_a_next_segment(tmp_path, verify_rrd, run_cli):
    rrd = tmp_path / "r.rrd"
    first, _, first_stop = _session(rrd, tmp_path / "state", 0, 10)
    size = rrd.stat().st_size
    second, status, second_stop = _session(rrd, tmp_path / "state", 5, 10)  # 5..9 again: a journal published again
    assert first.recordings == [rrd] and second.continued == [rrd] and second.recordings == [tmp_path / "r.1.rrd"]
    # the stop names the file the recorder finishes (issue 72: it named r.rrd while r.1.rrd was written)
    assert f"the footer of {rrd})" in first_stop and f"the footer of {tmp_path / 'r.1.rrd'})" in second_stop
    assert rrd.stat().st_size == size  # never rewritten
    assert status["rollouts"][JOB] == 5 and status["republished"][JOB] == 5  # 10..14 written, 5..9 held already
    summary = summarize(rrd)
    assert [s["path"] for s in summary["segments"]] == [str(rrd), str(tmp_path / "r.1.rrd")]
    job = summary["jobs"][JOB]
    assert job["rollouts"] == job["unique_rollouts"] == 15 and job["duplicates"] == []
    assert summarize(tmp_path / "r.1.rrd")["recording_id"] == summary["recording_id"]  # one recording for Rerun
    assert sorted(read_recording(rrd).rollouts.column("rollout_index").to_pylist()) == list(range(15))
    code, out, _ = run_cli("replay", str(rrd), str(tmp_path / "r.1.rrd"))
    assert code == 0 and "2 files read together: r.rrd, r.1.rrd" in out and f"job {JOB}: 15 roll-outs" in out
    assert out.count(f"job {JOB}") == 1  # the segment given beside its first file is not summarised again
    for path in (rrd, tmp_path / "r.1.rrd"):
        verify_rrd(path)


def test_a_file_that_is_not_a_deployments_recording_is_refused_in_one_line(tmp_path, run_cli):
    other = tmp_path / "notes.rrd"
    other.write_text("my notes\n")
    code, out, err = run_cli("up", "--record", str(other), "--insecure", "--workers", "0", "--no-model")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, err
    assert err.startswith(f"acnmp: error: --record {other}: exists but not a readable .rrd"), err
    assert other.read_text() == "my notes\n"
    with pytest.raises(ValueError, match="not a readable .rrd"):
        LocalDeployment("segments", workers=0, model=False, learner=False, record=other,
                        state_dir=tmp_path / "state").start()
    assert other.read_text() == "my notes\n"
