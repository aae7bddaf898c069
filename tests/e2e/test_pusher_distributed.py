"""The Pusher example (issue 33) --distributed: the roll-outs run on pusher (MuJoCo) workers, the
recorder draws every one by its end effector's path, and seed 0 gives the same result as in one
process (every method: roll-outs, success, final distance)."""
from __future__ import annotations

import json

import pytest
import rerun as rr

from clients.cli import main
from services.recording.replay import summarize

pytest.importorskip("gymnasium", reason="gymnasium is not installed (scripts/setup.sh installs it)")

SMALL = ["--seeds", "1", "--train-steps", "100", "--budget", "8", "--promp-budget", "8", "--quiet"]


@pytest.mark.slow
def test_pusher_distributed_equals_one_process_and_records_every_rollout(tmp_path, verify_rrd):
    rrd, remote, local = tmp_path / "pusher.rrd", tmp_path / "remote.json", tmp_path / "local.json"
    assert main(["experiment", "pusher", *SMALL, "--distributed", "--workers", "2", "--record", str(rrd),
                 "--json", str(remote)]) == 0
    assert main(["experiment", "pusher", *SMALL, "--json", str(local)]) == 0
    keys = ("method", "seed", "params", "rollouts", "success", "final_error", "lfd_error", "curve")
    runs = [[{k: r[k] for k in keys} for r in json.loads(p.read_text())["runs"]] for p in (remote, local)]
    assert runs[0] == runs[1]
    verify_rrd(rrd)
    jobs = summarize(rrd)["jobs"]
    for n, run in enumerate(json.loads(remote.read_text())["runs"]):
        # one evaluator per method, in order; a failed adaptation measures its next mean once more
        extra = 1 if run["method"] == "acnmp" and run["adapted"] and not run["success"] else 0
        assert jobs[f"pusher-{run['method']}-s0-{n}"]["rollouts"] == run["rollouts"] + extra
    reader = rr.chunk.RrdReader(rrd)
    entities = {c.entity_path for c in reader.stream(store=reader.recordings()[0])}
    assert {"/arm/pusher-acnmp-s0-1/effector", "/arm/pusher-acnmp-s0-1/object", "/arm/pusher-acnmp-s0-1/targets/goal"} <= entities
