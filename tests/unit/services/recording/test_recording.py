"""The .rrd writer fed directly (no recorder process) and reading recordings back."""
from __future__ import annotations

import numpy as np

from services.recording.events import rollout_event
from services.recording.replay import summarize
from services.recording.rrd_writer import RrdWriter


def test_writer_in_process_and_replay_counts(tmp_path):
    out = tmp_path / "direct.rrd"
    with RrdWriter(out) as writer:
        for i in range(4):
            writer.log_event(rollout_event("j", i, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0], worker="w"))
        writer.log_event(rollout_event("j", 2, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0], worker="w"))
    summary = summarize(out)
    job = summary["jobs"]["j"]
    assert (job["rollouts"], job["unique_rollouts"], job["duplicates"]) == (5, 4, [2])
    assert job["best_return"] == 1.0


def test_replay_cli_errors_cleanly(tmp_path, capsys):
    from clients.cli import main

    assert main(["replay", str(tmp_path / "missing.rrd")]) == 1
    junk = tmp_path / "junk.rrd"
    junk.write_bytes(b"not a recording")
    assert main(["replay", str(junk)]) == 1
    assert "acnmp replay" in capsys.readouterr().err


def test_replay_of_a_recording_still_being_written_says_so(tmp_path, capsys):
    """Issue 36, row 8: a recording being written was reported as one whose writer "did not shut
    down cleanly"; replay says it is still being written (by whom), and the warning stays for a
    file without footer that nobody writes."""
    import os
    import shutil

    from clients.cli import main

    out = tmp_path / "live.rrd"
    with RrdWriter(out) as writer:
        for i in range(3):
            writer.log_event(rollout_event("j", i, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0], worker="w"))
        writer.rec.flush(timeout_sec=10)  # on disk, the file still open and without footer
        assert main(["replay", str(out)]) == 0
        text = capsys.readouterr().out
        shutil.copyfile(out, tmp_path / "left.rrd")  # what a writer killed now would leave
    assert f"still being written (open for writing by pid {os.getpid()})" in text
    assert "job j: 3 roll-outs" in text and "did not shut down cleanly" not in text

    left = tmp_path / "left.rrd"
    assert main(["replay", str(left)]) == 0  # just written, by nobody: perhaps a writer of another user
    assert "perhaps still being written" in capsys.readouterr().out
    os.utime(left, (1e9, 1e9))  # long ago
    assert main(["replay", str(left)]) == 0
    text = capsys.readouterr().out
    assert "did not shut down cleanly" in text and "being written" not in text
    assert main(["replay", str(out)]) == 0  # closed: its footer is written
    assert "being written" not in capsys.readouterr().out and summarize(out)["writer"]["state"] == "complete"


def test_a_recording_is_readable_by_its_owner_only(tmp_path):
    """Issue 31: roll-outs are the user's data, written 0600 like the deployment's secrets, also over
    a file that existed with wider permissions."""
    import stat

    old = tmp_path / "old.rrd"
    old.write_bytes(b"")
    old.chmod(0o644)
    for out in (tmp_path / "new.rrd", old):
        with RrdWriter(out) as writer:
            writer.log_event(rollout_event("j", 0, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0], worker="w"))
        assert stat.S_IMODE(out.stat().st_mode) == 0o600, out


def test_a_flush_writes_what_was_logged_and_names_the_learner_rollouts_now_in_the_file(tmp_path):
    """Issue 73: the recorder says which roll-outs its file holds only once they are in it (a copy
    of the open file, what a recorder killed now would leave, holds them)."""
    import shutil

    out = tmp_path / "flushed.rrd"
    with RrdWriter(out) as writer:
        for i in range(3):  # a learner job's roll-outs carry their attempt; an experiment's none
            writer.log_event({**rollout_event("e1-0123456789", i, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0]),
                              "attempt": 0})
        writer.log_event(rollout_event("j", 0, np.zeros((3, 2)), [0, 0.5, 1], [0, 0, 1.0]))
        assert writer.flush() == [f"rollout/e1-0123456789/{i}" for i in range(3)]
        shutil.copyfile(out, tmp_path / "left.rrd")
        assert writer.flush() == []  # nothing logged since
    assert summarize(tmp_path / "left.rrd")["jobs"]["e1-0123456789"]["unique_rollouts"] == 3
    assert writer.flush() == []  # closed
