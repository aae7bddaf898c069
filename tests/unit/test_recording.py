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
