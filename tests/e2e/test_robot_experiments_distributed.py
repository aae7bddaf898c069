"""E5 and E6 --distributed: the roll-outs run on ur10 / pour workers, the recorder logs every one
with its drawing (the UR10's posed meshes, the marbles), and the counts match the JSON."""
from __future__ import annotations

import json

import pytest
import rerun as rr

from clients.cli import main
from services.recording.replay import summarize


def _entities(path) -> set[str]:
    reader = rr.chunk.RrdReader(path)
    return {c.entity_path for c in reader.stream(store=reader.recordings()[0])}


@pytest.mark.slow
def test_ur10_cli_distributed_records_every_rollout(tmp_path, monkeypatch, ur10_demo_file, verify_rrd, capsys):
    monkeypatch.setenv("ACNMP_CACHE", str(ur10_demo_file.parent))
    rrd, out = tmp_path / "e5.rrd", tmp_path / "e5.json"
    assert main(["experiment", "ur10", "--seeds", "1", "--train-steps", "100", "--budget", "2", "--cases", "8_10,9_11", "--distributed",
                 "--workers", "2", "--record", str(rrd), "--json", str(out), "--quiet"]) == 0
    verify_rrd(rrd)
    r = json.loads(out.read_text())
    jobs = summarize(rrd)["jobs"]
    # evaluators in order: the expert at each case (jobs 0, 1), then each case of the seed (2, 3)
    for n, case in enumerate(("8_10", "9_11")):
        assert jobs[f"ur10-{case}-{n}"]["rollouts"] == 1
        run = next(x for x in r["runs"] if x["case"] == case)["acnmp"]
        extra = 0 if run["success"] else 1  # a failed run executes its final mean once more
        assert jobs[f"ur10-{case}-{n + 2}"]["rollouts"] == run["rollouts"] + extra
    assert any(e.startswith("/arm/ur10-9_11-3/robot/") for e in _entities(rrd))
    # the recording audits itself: every UR10 roll-out run again in this process, the same return
    capsys.readouterr()
    assert main(["replay", str(rrd), "--execute", "--json"]) == 0
    audit = json.loads(capsys.readouterr().out)
    assert audit["rollouts"] == audit["equal"] == sum(j["rollouts"] for j in jobs.values()) and not audit["skipped_jobs"]


@pytest.mark.slow
def test_pour_cli_distributed_records_every_rollout(tmp_path, monkeypatch, pour_demo_file, verify_rrd):
    monkeypatch.setenv("ACNMP_CACHE", str(pour_demo_file.parent))
    rrd, out = tmp_path / "e6.rrd", tmp_path / "e6.json"
    assert main(["experiment", "pour", "--seeds", "1", "--train-steps", "100", "--budget", "2", "--no-assimilation",
                 "--distributed", "--workers", "2", "--record", str(rrd), "--json", str(out), "--quiet"]) == 0
    verify_rrd(rrd)
    r = json.loads(out.read_text())
    job = summarize(rrd)["jobs"]["pour-0"]
    run = r["runs"][0]
    assert job["rollouts"] == run["rollouts"] + (0 if run["success"] else 1)
    assert r["rollout_cpu_s_median"] is None  # measured in-process only
    assert {"/arm/pour-0/points", "/arm/pour-0/holder", "/poured_g/pour-0"} <= _entities(rrd)
