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
