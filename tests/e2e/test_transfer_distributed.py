"""E4 --distributed: robot B's roll-outs run on planar4 workers and the recorder logs every one,
per condition, with the counts of the JSON."""
from __future__ import annotations

import json

from clients.cli import main
from services.recording.replay import summarize


def test_transfer_cli_distributed_records_every_rollout(tmp_path, verify_rrd):
    rrd, out = tmp_path / "e4.rrd", tmp_path / "e4.json"
    assert main(["experiment", "transfer", "--runs", "1", "--pair-steps", "50", "--budget", "4", "--no-authors-data",
                 "--distributed", "--workers", "1", "--record", str(rrd), "--json", str(out), "--quiet"]) == 0
    verify_rrd(rrd)
    r = json.loads(out.read_text())
    jobs = summarize(rrd)["jobs"]
    assert [x["condition"] for x in r["per_run"]] == ["transfer", "no_alignment", "no_transfer"]
    for n, run in enumerate(r["per_run"]):  # one evaluator per condition, in order
        job = jobs[f"transfer-{run['condition']}-{n}"]
        assert job["rollouts"] == run["rollouts"] and not job["duplicates"]
