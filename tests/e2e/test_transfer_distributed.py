"""E4 --distributed: the pairs trained by the learner, robot B's first attempt from the model
service's transfer query, its roll-outs on planar4 workers, every one recorded per condition with
the counts of the JSON; the numbers equal the in-process run's."""
from __future__ import annotations

import json
from dataclasses import replace

import pytest
import rerun as rr

from acnmp_core.experiments.transfer import TransferExperimentConfig, run_transfer
from clients.cli import main
from services.recording.replay import summarize


@pytest.mark.slow
def test_transfer_cli_distributed_records_every_rollout(tmp_path, verify_rrd):
    rrd, out = tmp_path / "e4.rrd", tmp_path / "e4.json"
    assert main(["experiment", "transfer", "--seeds", "1", "--pair-steps", "50", "--budget", "4", "--no-authors-data",
                 "--distributed", "--workers", "1", "--record", str(rrd), "--json", str(out), "--quiet"]) == 0
    verify_rrd(rrd)
    r = json.loads(out.read_text())
    # the deployment it started: authenticated, as `acnmp up` is, its worker and recording
    assert {k: v for k, v in r["deployment"].items() if k != "namespace"} == {
        "attached": False, "workers": 1, "recording": str(rrd), "authenticated": True}
    summary = summarize(rrd)
    jobs = summary["jobs"]
    assert [x["condition"] for x in r["per_run"]] == ["transfer", "no_alignment", "no_transfer"]
    for n, run in enumerate(r["per_run"]):  # one evaluator per condition, in order
        job = jobs[f"transfer-{run['condition']}-{n}"]
        assert job["rollouts"] == run["rollouts"] and not job["duplicates"]
    # the pairs came from the learner: their jobs and both robots' 12 latents each are in the recording
    assert sorted(r["pair_jobs"]) == ["e4-aligned-0", "e4-plain-0"]
    assert all(summary["skills"][skill]["latents"] == 24 for skill in r["pair_jobs"])
    reader = rr.chunk.RrdReader(rrd)
    entities = {c.entity_path for c in reader.stream(store=reader.recordings()[0])}
    assert "/arm/transfer-transfer-0/reference" in entities  # robot A's demonstration beside robot B
    # robot B's first attempt from the model service is the trajectory the RL started from
    assert [x["first_attempt_diff"] for x in r["per_run"]] == [0.0, 0.0, None]

    # the same numbers as in one process
    cfg = TransferExperimentConfig()
    cfg.pair, cfg.adapt = replace(cfg.pair, steps=50), replace(cfg.adapt, max_rollouts=4)
    local = run_transfer(1, cfg=cfg, authors_data=False)
    for mine, theirs in zip(local["per_run"], r["per_run"]):
        theirs = {k: v for k, v in theirs.items() if k not in ("time_s", "first_attempt_diff")}
        assert {k: v for k, v in mine.items() if k != "time_s"} == theirs
    assert local["conditions"] == r["conditions"] and local["latent_alignment"] == r["latent_alignment"]
